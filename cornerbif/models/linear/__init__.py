"""The ``linear`` model: a user's own linear multi-degree-of-freedom vibro-impact system,
declared in a scene's ``[system]`` (docs/linear.md): its declarations, exact flights, impact
law, certified event loop and the model object, all in this folder."""
