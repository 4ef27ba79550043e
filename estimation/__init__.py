"""Identification: encoder smoothing, energy balances, least squares, tensor, uncertainty."""
