"""Gimbal model, geometry, device description and the virtual device."""
