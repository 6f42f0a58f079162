"""``rfsim run link`` end to end on a tiny config (issue 4, item 8)."""

from __future__ import annotations

import numpy as np
import pytest

from rfsim.cli import main

FIELDS = ("time_s", "true_distance_m", "antenna_port", "channel_index", "peak_rssi_dbm", "phase_angle_rad",
          "doppler_frequency_hz", "snr_db", "success", "failure_reason", "true_incident_power_dbm")


def test_rfsim_run_link_writes_reads_and_figure(tmp_path, capsys):
    xr = pytest.importorskip("xarray")
    # 1 m and 2 m are well inside the range (≈ 6.6 m in free space for the default 30 dBm,
    # 6 dBi patch, PASS chip sensitivity; the APDP fades of the default channel are a few
    # dB), 20 m is far outside (free-space incident power ≈ −22 dBm there, plus the fades).
    distances = (1.0, 2.0, 20.0)
    rc = main(["run", "link", "--seed", "3", "--out-dir", str(tmp_path),
               "--set", f"geometry.distances_m={list(distances)}", "--set", "rounds_per_point=2"])
    assert rc == 0
    assert "dataset:" in capsys.readouterr().out
    path = tmp_path / "link.h5"
    assert path.exists() and (tmp_path / "link-rssi-read-rate.png").exists()
    with xr.open_dataset(path, engine="h5netcdf", group="reads") as reads:
        for field in FIELDS:
            assert field in reads, field
        n = reads.sizes[next(iter(reads.sizes))]
        assert n == 2 * len(distances)
        d = reads["true_distance_m"].values
        ok = reads["success"].values.astype(bool)
        reasons = reads["failure_reason"].values.astype(str)
        rssi = reads["peak_rssi_dbm"].values
        assert reads["peak_rssi_dbm"].attrs["units"] == "dBm"
        near = d < 5
        assert ok[near].all() and (reasons[near] == "").all()
        assert not ok[~near].any() and (reasons[~near] == "not powered").all()
        assert np.isnan(rssi[~near]).all()
        mean_rssi = [rssi[d == x].mean() for x in distances[:2]]
        assert mean_rssi[0] > mean_rssi[1] + 6  # ≈ 12 dB (d⁻⁴) apart, fades aside
        inc = reads["true_incident_power_dbm"].values
        assert inc[d == 1.0].min() > inc[d == 20.0].max()
        assert set(np.unique(reads["antenna_port"].values)) == {1}
        ch = reads["channel_index"].values
        assert ((ch >= 1) & (ch <= 50)).all()
        assert np.all(np.isfinite(reads["phase_angle_rad"].values[ok]))
        assert np.all((reads["phase_angle_rad"].values[ok] >= 0) & (reads["phase_angle_rad"].values[ok] < 2 * np.pi))
        assert np.all(np.diff(reads["time_s"].values) > 0)
