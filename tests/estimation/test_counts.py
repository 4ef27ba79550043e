"""A drive logger's integer counts from a wrapping counter identify as the phi logs do."""

from __future__ import annotations

import numpy as np

from rsp_inertia.identifying import identify
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.logs import read_log
from tests.conftest import copy_experiment


def test_wrapped_counts_identify_like_the_angles(tmp_path, default_logs):
    """The default experiment's logs rewritten as a 16-bit counter's counts (which wrap, and
    start a whole turn away: -30 deg reads as 330 deg): the same tensor to 1e-9 of it."""
    root = copy_experiment(default_logs, tmp_path / "exp")
    phi_result = identify(root)
    device = load_device(root / "device.toml")
    q = device.encoder.quantum
    for path in sorted(root.glob("stage*/braking.csv")) + sorted(root.glob("stage*/reverse.csv")):
        kind = "braking" if path.name.startswith("braking") else "reverse"
        log = read_log(path, device.encoder, kind)
        counts = np.round(log.phi / q).astype(np.int64) % 2**16
        rows = [f"{float(t)!r},{int(c)},{float(u)!r}" for t, c, u in zip(log.t, counts, log.torque)]
        path.write_text("t,counts,torque\n" + "\n".join(rows) + "\n")
    text = (root / "device.toml").read_text()
    assert "\ncounts_per_rev = 65536" in text
    (root / "device.toml").write_text(
        text.replace("\ncounts_per_rev = 65536", "\ncounter_bits = 16\ncounts_per_rev = 65536", 1)
    )
    counts_result = identify(root)
    np.testing.assert_allclose(counts_result.entries, phi_result.entries, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(
        np.sqrt(np.diag(counts_result.entries_cov)), np.sqrt(np.diag(phi_result.entries_cov)),
        rtol=1e-6,
    )
