"""Swimming dynamics of the robotic fish (the pure model in :mod:`fishtail_plant.fish`)."""
