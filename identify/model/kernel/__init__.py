"""The compiled forward model (numba): the fast twin of identify.model.evaluate,
its branch-free equations, vectorisable maths and cache stamp."""
