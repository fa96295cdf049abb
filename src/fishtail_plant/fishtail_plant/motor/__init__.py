"""The DC gear motor, the first-order motor, the motor board's speed loop and its units."""
