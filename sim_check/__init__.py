"""Closed-loop simulation: the generated MLCA controllers driving autonomous vehicles in SUMO through libsumo."""
