"""The swimming simulator node (markers, tf) and the ``fishtail-swim`` command line.

The fish it simulates is :mod:`fishtail_plant`; docs/swimming-dynamics.md.
"""
