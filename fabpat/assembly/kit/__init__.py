"""The kit (paper §5): ``build`` (:func:`assemble`: a spec in, a folder of parts out), ``result`` (what it
returns, the plates' fabrication checks), ``files`` (every output written), ``folder`` (what may be replaced,
and the swap), ``bom`` (bill of materials and joint table), ``sheets`` (laser sheets), ``net`` (the unfolding),
``panel`` and ``panel_bom`` (a one-piece panel's kit and BOM)."""
