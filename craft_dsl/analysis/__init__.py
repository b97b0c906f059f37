"""Analyses of the physics, apart from the physics itself: scene statistics over many seeds, and how often two
engines give the same answers (which imports the templates and simulates twice)."""
