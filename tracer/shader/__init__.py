"""Shader programs: the node trees of materials compiled to instructions the tracer runs per hit
(program.py), in families of instructions (closures.py, inputs.py)."""
