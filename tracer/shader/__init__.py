"""Shader programs: the node families the tracer's interpreter runs at each hit."""
