"""`ratfit.distributed.fit_many` on a Dask LocalCluster of two worker
processes: one task per material and channel, failures kept apart."""

import numpy as np
import pytest

import ratfit
from ratfit.distributed import fit_many

distributed = pytest.importorskip("dask.distributed")

SETTINGS = dict(format="rgl", dims=2, resolution=(24, 24), rel_tol=0.1, max_coeffs=40, render_check=False)


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    )
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_fit_many_matches_local_fits_and_reports_failures(client, data_dir, tmp_path):
    good = [
        str(data_dir / "rgl" / "cm_military_green_rgb.bsdf"),
        str(data_dir / "rgl" / "vch_golden_yellow_rgb.bsdf"),
    ]
    missing = str(tmp_path / "missing.bsdf")
    results = fit_many([good[0], missing, good[1]], SETTINGS, client)
    assert [r.path for r in results] == [good[0], missing, good[1]]
    # Both workers took part: tasks are spread, not run in the client.
    assert len(client.scheduler_info()["workers"]) == 2
    rng = np.random.default_rng(5)
    wi = rng.normal(size=(40, 3))
    wi[:, 2] = np.abs(wi[:, 2]) + 0.1
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = wi * np.array([-1, -1, 1])
    for r, path in zip([results[0], results[2]], good):
        assert r.ok, r.errors
        assert all(isinstance(f, ratfit.RationalFit) for f in r.channels)
        assert all(rep["verified"] for rep in r.channel_reports)
        local = ratfit.fit_brdf(path, **SETTINGS)
        assert np.array_equal(r.fitted.eval(wi, wo), local.eval(wi, wo))
    bad = results[1]
    assert not bad.ok and bad.fitted is None
    assert set(bad.errors) == {"channel 0", "channel 1", "channel 2"}
    assert all("FileNotFoundError" in e and "missing.bsdf" in e for e in bad.errors.values())


def test_fit_many_refuses_bad_settings_before_submitting(client):
    with pytest.raises(ValueError, match="unknown"):
        fit_many(["a.bsdf"], dict(SETTINGS, rel_tolerance=0.1), client)
