"""Shader node families compiled into shader programs (see docs/architecture.md)."""
