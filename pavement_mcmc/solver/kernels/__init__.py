"""Compiled (numba) kernels of the solver and its adjoint; internal."""
