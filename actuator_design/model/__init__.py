"""The model: a scene, its profiles, units, expressions, materials, magnetisation and the field sources from geometry."""
