"""Obstacles z(t) of the ``flow`` model: the jitted dispatch over the obstacle codes
(``dispatch``) and cam profiles (``profile``)."""
