"""Physics of the models as plain data (parameter layouts) and small jitted pieces."""
