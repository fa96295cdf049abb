"""The fish in the plane: body, forces, the integrator and its compiled twin, beat figures."""
