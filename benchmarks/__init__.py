"""Benchmarks of btgen_pytrees: ``python -m benchmarks.run`` (see ``docs/performance.md``).

Not part of the installed package: they live beside it so that they measure the
working tree, and only use its public entry points (``load``, ``timeline``,
``generate``, ``run_tree``) so that they keep working while its insides change.
"""
