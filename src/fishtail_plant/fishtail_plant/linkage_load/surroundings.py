"""Where the tail moves, from no load to the swimming fish: the choices of the carrier's load.

Apart from :mod:`~fishtail_plant.linkage_load.tail_load` so that a driver can offer the choices
without loading the fish dynamics (numba) that a load needs.
"""

#: The surroundings a tail can work in, from no load to the swimming fish.
SURROUNDINGS = ("none", "air", "water_held", "water_swimming")
#: The motor turns freely.
NO_LOAD = "none"
