"""The ``flow`` model (sections 2-3): its parameters and packed row, the model object,
its event-loop kernel and its time series, all in this folder."""
