"""The ``map2d`` model (sections 4-5): the local maps alpha, beta, gamma as a kernel,
and the model object."""
