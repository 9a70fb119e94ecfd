"""Other minima of an MF stage: the other branch of a load curve, coefficients whose
effect is even, sign-keeping images and rival minima."""
