"""Numerics shared by the models: closed-form flights of the oscillator, impact law (5),
the certified first-root search, output fills."""
