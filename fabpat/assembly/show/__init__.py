"""Pictures and 3-D files of a placed assembly: ``export`` (STEP, STL, GLB with y up, colours) and ``render``
(PNG drawings of the placement)."""
