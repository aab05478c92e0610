"""URDF assets: load in yourdfpy and Pinocchio, close every leg loop, match the kinematics."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import trimesh
import yourdfpy

from tests.conftest import random_hybrid_states
from twin.assets import asset_path
from twin.mechanisms import MECHANISMS
from twin.mechanisms.urdf import joint_configuration, joint_names
from twin.spatial import pose_to_transform

ROOT = Path(__file__).resolve().parents[2]


def random_states(name: str, rng: np.random.Generator, n: int) -> np.ndarray:
    mechanism = MECHANISMS[name]()
    if name == "hybrid":
        return random_hybrid_states(rng, n)
    lo, hi = (np.asarray(v, float) for v in mechanism.state_limits)
    mid = (lo + hi) / 2
    return rng.uniform(mid + 0.5 * (lo - mid), mid + 0.5 * (hi - mid), size=(n, lo.size))


def hinge_targets(mechanism, state: np.ndarray) -> np.ndarray:
    """Platform hinges in the base frame, from the mechanism's own pose (n, 3)."""
    T = pose_to_transform(mechanism.platform_pose(state))
    return (T[:3, :3] @ mechanism.layout.platform_hinges.T).T + T[:3, 3]


@pytest.fixture(scope="module", params=sorted(MECHANISMS))
def loaded(request):
    name = request.param
    path = asset_path("urdf", f"{name}.urdf")
    urdf = yourdfpy.URDF.load(str(path), load_meshes=True)
    model = pin.buildModelFromUrdf(str(path))
    return name, MECHANISMS[name](), urdf, model


def test_joint_names_and_limits_are_the_codes(loaded) -> None:
    """Same joints as `joint_names`, strokes limited by the layout's leg limits."""
    name, mechanism, urdf, _ = loaded
    assert tuple(urdf.actuated_joint_names) == joint_names(mechanism)
    for i in range(mechanism.layout.n_legs):
        limit = urdf.joint_map[f"leg{i + 1}_stroke"].limit
        assert (limit.lower, limit.upper) == pytest.approx(
            (mechanism.layout.length_min[i], mechanism.layout.length_max[i])
        )
    if name == "hybrid":
        lower, upper = mechanism.lower, mechanism.upper
        for k, joint in enumerate(("slew", "luff", "telescope")):
            limit = urdf.joint_map[joint].limit
            assert (limit.lower, limit.upper) == pytest.approx((lower[6 + k], upper[6 + k]))


def test_meshes_load(loaded) -> None:
    """Every visual mesh file exists and loads (the scene draws from these)."""
    _, _, urdf, _ = loaded
    assert len(urdf.scene.geometry) >= 4


def test_legs_close_on_platform_hinges_yourdfpy(loaded, rng: np.random.Generator) -> None:
    """With `joint_configuration`, each leg's rod tip is on its platform hinge to 1e-9 m."""
    name, mechanism, urdf, _ = loaded
    for state in random_states(name, rng, 20):
        cfg = {k: float(v) for k, v in joint_configuration(mechanism, state).items()}
        urdf.update_cfg(cfg)
        targets = hinge_targets(mechanism, state)
        for i, target in enumerate(targets):
            tip = urdf.get_transform(f"leg{i + 1}_rod", "base")[:3, 3]
            np.testing.assert_allclose(tip, target, atol=1e-9)
        platform = urdf.get_transform("platform", "base")
        np.testing.assert_allclose(
            platform, pose_to_transform(mechanism.platform_pose(state)), atol=1e-9
        )


def pinocchio_placements(model, cfg: dict[str, float]) -> pin.Data:
    data = model.createData()
    q = pin.neutral(model)
    for j in range(1, model.njoints):
        q[model.joints[j].idx_q] = cfg[model.names[j]]
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    return data


def test_legs_close_and_tip_matches_in_pinocchio(loaded, rng: np.random.Generator) -> None:
    """Pinocchio, an independent URDF reader and FK, agrees: loops closed, tip = ᴮT_E."""
    name, mechanism, _, model = loaded
    for state in random_states(name, rng, 20):
        cfg = {k: float(v) for k, v in joint_configuration(mechanism, state).items()}
        data = pinocchio_placements(model, cfg)
        for i, target in enumerate(hinge_targets(mechanism, state)):
            frame = model.getFrameId(f"leg{i + 1}_rod")
            np.testing.assert_allclose(data.oMf[frame].translation, target, atol=1e-9)
        if name == "hybrid":
            tip = data.oMf[model.getFrameId("gangway_tip")].homogeneous
            np.testing.assert_allclose(tip, mechanism.end_effector(state), atol=1e-9)


#: [m, rad] how far a regenerated URDF number may lie from the committed one: the file keeps
#: 12 significant digits (scripts/build_urdf.py), so a release of numpy, scipy or trimesh
#: moves a number by ~1e-15 relative and the 12-digit rounding by at most 5e-12 relative.
URDF_ATOL = 1e-9
#: [m] meshes are binary STL, float32: 2e-6 m is one float32 step at 16 m.
MESH_ATOL = 1e-5


def _numbers(text: str) -> list[float] | None:
    """The floats of a space-separated attribute, or None when it is not all numbers."""
    try:
        return [float(word) for word in text.split()]
    except ValueError:
        return None


def assert_urdf_close(made: Path, committed: Path, atol: float) -> None:
    """Same elements and attributes in the same order; numbers within `atol`, text equal."""
    made_root, committed_root = ET.parse(made).getroot(), ET.parse(committed).getroot()
    made_elements, committed_elements = list(made_root.iter()), list(committed_root.iter())
    assert len(made_elements) == len(committed_elements), f"{made.name}: element count"
    for a, b in zip(made_elements, committed_elements, strict=True):
        where = f"{made.name} <{b.tag} {b.attrib.get('name', '')}>"
        assert a.tag == b.tag and sorted(a.attrib) == sorted(b.attrib), where
        for key, value in b.attrib.items():
            x, y = _numbers(a.attrib[key]), _numbers(value)
            if y is None:
                assert a.attrib[key] == value, f"{where} {key}"
            else:
                assert x is not None and len(x) == len(y), f"{where} {key}"
                np.testing.assert_allclose(x, y, rtol=0, atol=atol, err_msg=f"{where} {key}")


def test_assets_are_reproducible(tmp_path: Path) -> None:
    """scripts/build_urdf.py regenerates the committed URDF and meshes, compared numerically.

    Numbers within `URDF_ATOL`, mesh vertices within `MESH_ATOL` with the same faces: a new
    numpy, scipy or trimesh release that moves a last bit must not fail a fresh install.
    """
    subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "build_urdf.py"), "--out", str(tmp_path)],
        check=True,
        capture_output=True,
        cwd=ROOT,
    )
    committed = asset_path("urdf")
    made_files = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*.*"))
    committed_files = sorted(p.relative_to(committed) for p in committed.rglob("*.*"))
    assert made_files == committed_files
    for relative in made_files:
        if relative.suffix == ".urdf":
            assert_urdf_close(tmp_path / relative, committed / relative, URDF_ATOL)
            continue
        made = trimesh.load(tmp_path / relative, process=False)
        kept = trimesh.load(committed / relative, process=False)
        np.testing.assert_array_equal(made.faces, kept.faces, err_msg=str(relative))
        np.testing.assert_allclose(
            made.vertices, kept.vertices, rtol=0, atol=MESH_ATOL, err_msg=str(relative)
        )


def test_asset_comparison_catches_a_moved_joint(tmp_path: Path) -> None:
    """The numeric comparison is not vacuous: a joint 1e-6 m off fails it, 1e-12 m passes."""
    committed = asset_path("urdf", "upr4.urdf")
    text = committed.read_text()
    origin = ET.parse(committed).getroot().find("joint/origin")
    assert origin is not None
    xyz = origin.attrib["xyz"]
    first = float(xyz.split()[0])
    for shift, fails in ((1e-6, True), (1e-12, False)):
        moved = xyz.replace(xyz.split()[0], repr(first + shift), 1)
        (tmp_path / "upr4.urdf").write_text(text.replace(f'xyz="{xyz}"', f'xyz="{moved}"', 1))
        if fails:
            with pytest.raises(AssertionError):
                assert_urdf_close(tmp_path / "upr4.urdf", committed, URDF_ATOL)
        else:
            assert_urdf_close(tmp_path / "upr4.urdf", committed, URDF_ATOL)
