"""Shader programs: node families the interpreter runs (see docs/architecture.md)."""
