"""Shader node families compiled into shader program rows."""
