"""Tolerances of a lab and designs that hold over them: the tolerance box, robust design, snap distances."""
