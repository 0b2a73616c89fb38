"""The ``two_particle`` model (section 6): its parameters and packed row, the model
object and its event-loop kernel, all in this folder."""
