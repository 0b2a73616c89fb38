"""Impact laws."""

from .._jit import jit


@jit
def restitution(v_in, z_slope, r):
    """Newton's law (5): v+ = (1 + r) dz/dt - r v-.

    The relative velocity to the obstacle is reversed and scaled by r; dz/dt is
    the slope of the smooth piece the impact lies in.
    """
    return (1.0 + r) * z_slope - r * v_in
