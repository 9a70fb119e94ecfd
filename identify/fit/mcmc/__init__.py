"""MCMC uncertainty of a fitted problem (emcee): the chains, their stepping, the
Laplace independence move and the reparametrisation of the cornering-stiffness ridge."""
