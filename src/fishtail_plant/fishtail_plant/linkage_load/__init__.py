"""The tail as the motor's load: link inertia, the carrier's torque, the water on the fin."""
