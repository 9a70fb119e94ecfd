"""The least-squares engine: fit problems, the bounded solver and its tolerances,
Gauss-Newton steps, finite-difference Jacobians, the constrained polish and the covariance
of the estimates."""
