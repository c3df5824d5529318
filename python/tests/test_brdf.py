"""`ratfit.fit_brdf`, `FittedMaterial` and `read_material` on a real RGL file,
checked against the CLI (the same JSON, values and exports)."""

import json
import subprocess

import numpy as np
import pytest

import ratfit

SMALL = dict(dims=2, resolution=(30, 30), rel_tol=0.1, max_coeffs=40)


@pytest.fixture(scope="module")
def military_green(data_dir):
    return str(data_dir / "rgl" / "cm_military_green_rgb.bsdf")


@pytest.fixture(scope="module")
def fitted(military_green):
    return ratfit.fit_brdf(military_green, **SMALL)


def directions(n, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(2, n, 3))
    v[..., 2] = np.abs(v[..., 2]) + 0.05
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return v[0], v[1]


def test_fit_reports_what_it_reached(fitted):
    r = fitted.report
    assert all(c["verified"] for c in r["report"]["channels"])
    # The default render check: both validation scenes, finite errors.
    scenes = r["render"]["scenes"]
    assert len(scenes) == 2 and all(0 <= s["mean_de"] < 30 for s in scenes)
    # With the part of it the luminance and the colour each cause.
    split = r["render"]["colour_split"]
    for part in ("luminance_mean_de", "colour_mean_de"):
        assert len(split[part]) == 2 and all(0 <= e < 30 for e in split[part])
    # The coefficients and the ceiling (three f32) on the RGB values.
    assert fitted.nbytes == 4 * fitted.coefficients + 12
    ceiling = json.loads(fitted.to_json())["brdf"]["ceiling"]
    assert len(ceiling) == 3 and all(c > 0 for c in ceiling)
    assert [c.dim for c in fitted.channels] == [2, 2, 2]
    assert fitted.value_scale == "linear"


def test_a_fit_on_the_log_scale_says_so_and_round_trips(military_green):
    log = ratfit.fit_brdf(military_green, values="log", **SMALL)
    assert log.value_scale == "log"
    assert json.loads(log.to_json())["brdf"]["scale"] == "log"
    assert all(c["verified"] for c in log.report["report"]["channels"])
    wi, wo = directions(16, 2)
    ours = log.eval(wi, wo)
    # exp(p / q): positive everywhere above the surface.
    assert np.all(np.isfinite(ours)) and np.all(ours > 0)
    back = ratfit.FittedMaterial.from_json(log.to_json())
    assert back.value_scale == "log"
    assert np.array_equal(back.eval(wi, wo), ours)


def test_values_and_json_agree_with_the_cli(tmp_path, cli, fitted, military_green):
    wi, wo = directions(64, 1)
    ours = fitted.eval(wi, wo)
    assert ours.shape == (64, 3) and np.all(np.isfinite(ours))
    path = tmp_path / "fit.json"
    path.write_text(fitted.to_json())
    # The CLI reads our file and evaluates it by the same Rust code.
    rows = []
    for a, b in zip(wi, wo):
        rows.append([np.arccos(a[2]), np.arctan2(a[1], a[0]), np.arccos(b[2]), np.arctan2(b[1], b[0])])
    np.savetxt(tmp_path / "dirs.csv", np.array(rows), delimiter=",")
    printed = subprocess.run(
        [cli, "eval", str(path), "--directions", str(tmp_path / "dirs.csv")],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    rust = np.array([[float(v) for v in line.split(",")] for line in printed.split()])
    assert np.max(np.abs(rust - ours) / np.maximum(np.abs(ours), 1e-300)) < 1e-12
    # Exports equal the CLI's.
    wgsl = subprocess.run(
        [cli, "export", str(path), "--to", "wgsl"], check=True, capture_output=True, text=True
    ).stdout
    assert wgsl == fitted.export("wgsl")
    subprocess.run([cli, "export", str(path), "--to", "binary", "-o", str(tmp_path / "f.bin")], check=True)
    assert (tmp_path / "f.bin").read_bytes() == fitted.export("binary")
    # And a fit the CLI wrote reads here.
    out = tmp_path / "cli.json"
    subprocess.run(
        [cli, "fit", military_green, "--format", "rgl", "--dims", "2", "--resolution", "30,30",
         "--rel-tol", "0.1", "--max-coeffs", "40", "--no-render-check", "-o", str(out)],
        check=True,
        capture_output=True,
    )
    theirs = ratfit.FittedMaterial.from_json(out.read_text())
    assert np.array_equal(theirs.eval(wi, wo), ours)


def test_the_table_reads_and_evaluates(military_green, fitted):
    m = ratfit.read_material(military_green)
    wi, wo = directions(200, 2)
    table, fit = m.eval(wi, wo), fitted.eval(wi, wo)
    assert "military_green" in m.name
    # Saturated measured colours fall outside sRGB (a channel slightly
    # negative); the luminance never does.
    assert np.all(np.isfinite(table)) and np.all(table @ [0.2126, 0.7152, 0.0722] >= 0)
    # A 10% fit of the cells it saw: the median relative error is small.
    near = (wi[:, 2] > 0.5) & (wo[:, 2] > 0.5)
    assert np.median(np.abs(fit[near] / table[near] - 1)) < 0.1


def test_channels_fitted_apart_join_into_the_same_fit(military_green, fitted):
    options = dict(SMALL, render_check=False)
    parts = [ratfit._ratfit.fit_brdf_channel(military_green, c, options) for c in range(3)]
    joined = ratfit._ratfit.assemble_channels(military_green, parts, options)
    wi, wo = directions(50, 3)
    assert np.array_equal(joined.eval(wi, wo), fitted.eval(wi, wo))
    assert json.loads(joined.to_json())["brdf"] == json.loads(fitted.to_json())["brdf"]


def test_phi_d_as_its_cosine_is_recorded_and_round_trips(military_green):
    options = {**SMALL, "dims": 3, "resolution": (8, 8, 8), "rel_tol": 0.2, "phi": "cosine"}
    cos = ratfit.fit_brdf(military_green, **options)
    assert json.loads(cos.to_json())["brdf"]["reduction"]["phi"] == "cosine"
    assert all(c["verified"] for c in cos.report["report"]["channels"])
    wi, wo = directions(16, 2)
    back = ratfit.FittedMaterial.from_json(cos.to_json())
    assert np.array_equal(back.eval(wi, wo), cos.eval(wi, wo))


def test_a_centred_fit_says_so_and_stays_verified(military_green):
    centred = ratfit.fit_brdf(military_green, centred=True, render_check=False, **SMALL)
    channels = centred.report["report"]["channels"]
    assert all(c["verified"] and c["centred"] for c in channels)
    plain = ratfit.fit_brdf(military_green, render_check=False, **SMALL)
    assert not any(c["centred"] for c in plain.report["report"]["channels"])


@pytest.mark.parametrize(
    "options, message",
    [
        (dict(dims=4), "dims"),
        (dict(foo=1), "unknown"),
        (dict(rel_tol="x"), "rel_tol"),
        (dict(rel_tol=1.5), "tolerance"),
        (dict(resolution=(1, 2)), "resolution"),
        (dict(colour="cmyk"), "colour"),
        (dict(values="exp"), "values"),
        (dict(phi="sine"), "phi"),
        (dict(target_de=-1.0), "target_de"),
        (dict(target_de=1.0, max_bytes=4), "max_bytes"),
        (dict(max_bytes=1024), "max_bytes"),
        (dict(perceptual=True, cap_rounds=17), "cap_rounds"),
        (dict(format="obj"), "format"),
        (dict(centred="yes"), "centred"),
    ],
)
def test_bad_options_raise_value_error(military_green, options, message):
    with pytest.raises(ValueError) as info:
        ratfit.fit_brdf(military_green, **options)
    assert message in str(info.value), str(info.value)


def test_bad_files_raise(tmp_path):
    with pytest.raises(FileNotFoundError):
        ratfit.read_material(str(tmp_path / "missing.bsdf"))
    broken = tmp_path / "broken.bsdf"
    broken.write_bytes(b"tensor_file\x00" + b"\x01" * 40)
    with pytest.raises(ValueError) as info:
        ratfit.read_material(str(broken))
    assert "broken.bsdf" in str(info.value)
    with pytest.raises(ValueError, match="format"):
        ratfit.read_material(str(tmp_path / "table.txt"))
    with pytest.raises(ValueError, match="brdf"):
        ratfit.FittedMaterial.from_json('{"report": {}}')


def test_shapes_of_directions_are_checked(fitted):
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        fitted.eval(np.zeros((4, 2)), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="directions"):
        fitted.eval(np.zeros((4, 3)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="not finite"):
        fitted.eval(np.full((1, 3), np.nan), np.zeros((1, 3)))


def test_perceptual_fits_take_an_elevation_cut_only_when_asked(military_green):
    quick = dict(dims=2, resolution=(20, 20), rel_tol=0.16, perceptual=True,
                 max_coeffs=40, render_check=False)
    cuts = []
    for extra in ({}, {"max_elevation": 75.0}):
        f = ratfit.fit_brdf(military_green, **quick, **extra)
        cuts.append(json.loads(f.to_json())["brdf"]["reduction"]["max_elevation_deg"])
    # The whole hemisphere by default; the cut when given.
    assert cuts == [90.0, 75.0]
    # With the render check, a whole-hemisphere fit is evaluated within the
    # cut its renders prefer, as `ratfit fit` does.
    checked = ratfit.fit_brdf(military_green, **dict(quick, render_check=True))
    choice = checked.report["evaluation_cut"]
    # None, then four cuts, each without and with two shell factors (and
    # the lower cuts, 60 then 55 degrees, in turn while the lowest did
    # best), then four more shell layouts at the cut that did best.
    measured = []
    for t in choice["tried"]:
        if t["cut"] is not None and t["cut"] not in measured:
            measured.append(t["cut"])
    assert measured[:4] == [80.0, 75.0, 70.0, 65.0]
    lower = measured[4:]
    assert lower == [60.0, 55.0][:len(lower)]
    stage_one = 1 + 3 * len(measured)
    assert len(choice["tried"]) == stage_one + 4
    assert sum(t["shell"] for t in choice["tried"]) == 2 * len(measured) + 4
    more = choice["tried"][stage_one:]
    assert len({t["cut"] for t in more}) == 1
    assert all(t["shell_layout"]["spacing"] == "cosine" for t in more)
    chosen = json.loads(checked.to_json())["brdf"]["reduction"]["max_elevation_deg"]
    assert chosen == (choice["chosen"] or 90.0)
    # Fits at fixed intervals keep their 70-degree default.
    plain = ratfit.fit_brdf(military_green, **SMALL, render_check=False)
    assert json.loads(plain.to_json())["brdf"]["reduction"]["max_elevation_deg"] == 70.0
