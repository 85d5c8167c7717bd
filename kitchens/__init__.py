"""kitchens: one module per kitchen, each holding the kitchen's
:class:`executive.KitchenDescription` (as ``DESCRIPTION``) beside its URDF or the generator
of its URDF.

- :mod:`kitchens.iai`: the projection's kitchen (primitive shapes after CRAM's IAI kitchen:
  the sink counter with its drawer, the kitchen island), and CRAM's demo scene in it.

This package sits beside ``robots``, between ``executive`` (whose contract it fills in) and
``projection`` / ``aiocram`` (which read descriptions); ``plans`` and ``executive`` never
import it: plans read the kitchen from the environment (:attr:`executive.Environment.kitchen`).
"""
