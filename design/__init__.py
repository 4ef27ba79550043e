"""Experiment design: pilot fit, candidate protocols, rehearsal, plan, device.toml edit."""
