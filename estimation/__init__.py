"""Identification: smoothing, pass estimates, energy balances, least squares, tensor, calibration,
combining mountings, the torsion-pendulum baseline.

The names below are its public API, each from the module that is its home; they load on
first use (rsp_inertia.infra.lazy, as ``rsp_inertia`` does), so importing one module of the
package does not import the others.
"""

from __future__ import annotations

from rsp_inertia.infra.lazy import lazy_names

_HOMES = {
    "ExperimentLogs": "runs",
    "Sources": "runs",
    "identify_logs": "identify",
    "AxisResult": "results",
    "Identification": "results",
    "PendulumResult": "results",
    "KnownTerms": "known_terms",
    "TensorFit": "tensor_fit",
    "fit_tensor": "tensor_fit",
    "Smoothed": "smoothing",
    "smooth_log": "smoothing",
    "PassEstimate": "passes",
    "estimate_pass": "passes",
    "StageBalance": "balance",
    "stage_balance": "balance",
    "fit_modulated": "modulated",
    "Calibration": "calibration",
    "calibrate_logs": "calibration",
    "calibrated_known_terms": "calibration",
    "device_known_terms": "calibration",
    "CalibrationFile": "calibration_file",
    "CalibrationSummary": "calibration_summary",
    "read_calibration_file": "calibration_file",
    "write_calibration_file": "calibration_file",
    "calibrate_experiment": "reading",
    "identify_experiment": "reading",
    "read_calibration": "reading",
    "read_experiment": "reading",
    "Combination": "combine",
    "MountedResult": "combine",
    "combine_mountings": "combine",
    "estimate_pendulum": "pendulum",
}
"""Each public name and the module (of this package) that is its home."""

__all__ = [
    "AxisResult",
    "Calibration",
    "CalibrationFile",
    "CalibrationSummary",
    "Combination",
    "ExperimentLogs",
    "Identification",
    "KnownTerms",
    "MountedResult",
    "PassEstimate",
    "PendulumResult",
    "Smoothed",
    "Sources",
    "StageBalance",
    "TensorFit",
    "calibrate_experiment",
    "calibrate_logs",
    "calibrated_known_terms",
    "combine_mountings",
    "device_known_terms",
    "estimate_pass",
    "estimate_pendulum",
    "fit_modulated",
    "fit_tensor",
    "identify_experiment",
    "identify_logs",
    "read_calibration",
    "read_calibration_file",
    "read_experiment",
    "smooth_log",
    "stage_balance",
    "write_calibration_file",
]

__getattr__, __dir__ = lazy_names(__name__, _HOMES)
