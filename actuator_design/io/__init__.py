"""Files in and out: saving results, reading them back, safe writes and the units of outputs."""
