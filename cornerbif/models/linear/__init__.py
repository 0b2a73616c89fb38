"""The ``linear`` model (issue 33, being built): a user's own linear multi-degree-of-freedom
vibro-impact system declared in a scene.  So far its declarations, exact flights and impact
law (pure numpy, the reference for its kernel to come); not yet a registered model."""
