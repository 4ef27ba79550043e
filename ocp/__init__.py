"""Torque program of the reverse pass: mirrored reference, CasADi OCP, LQR regulator."""
