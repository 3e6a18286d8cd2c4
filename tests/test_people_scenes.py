"""The 3D scenes of the page: the model described once, the graph tasks' states as poses."""

import base64
import json

import mujoco
import numpy as np
import pytest

from hri_bench.people import scene3d
from hri_bench.people.serve import scenes
from hri_envs.physics.scene.kinematics import Pose, compose
from hri_envs.task.graph import ROBOT_BIT
from hri_envs.task.scenarios import episode_scenario, scenario_graph, scenario_spec


def _body(scene, name):
    return scene.bodies.index(mujoco.mj_name2id(scene.sim.model, mujoco.mjtObj.mjOBJ_BODY,
                                                name))


@pytest.mark.parametrize("scenario", ["hanger", "wheel"])
def test_a_graph_state_is_drawn_where_the_graph_puts_the_object_and_the_robot(scenario):
    """The object at the abstract state's pose; the robot's grip on the object's grip block
    when the robot holds it, away from it when it does not (who holds: the page's text)."""
    scene = scenes._GraphScene(scenario_graph(scenario))
    graph = scene.graph
    spec = scenario_spec(scenario)
    layout = None if spec.layout is None else spec.layout(np.random.default_rng(3))
    geometry = episode_scenario(scenario, layout)
    obj = _body(scene, "object")
    held = set()
    for state in range(graph.n_states):
        poses = np.array(scene.poses(layout, state)).reshape(-1, 7)
        scene.sim.set_scenario(geometry)
        pos, quat = scene.sim.observer.pose(state)
        assert np.allclose(poses[obj, :3], pos, atol=2e-4), graph.state_names[state]
        assert abs(abs(poses[obj, 3:] @ quat) - 1) < 1e-3
        grip = compose(Pose(poses[obj, :3], poses[obj, 3:]), *scene.sim.grip_in_object)
        scene.sim.reset(max(0, int(graph.support[state])), geometry, state=state)
        gap = np.linalg.norm(scene.sim.grip_pose().pos - grip.pos)
        robot = bool(graph.grasp[state] & ROBOT_BIT)
        assert (gap < 0.01) if robot else (gap > 0.03), (graph.state_names[state], gap)
        held.add(robot)
    assert held == {False, True}


def test_the_description_holds_the_visible_geoms_and_the_pandas_meshes():
    scene = scenes._GraphScene(scenario_graph("hanger"))
    doc = scene.doc
    model = scene.sim.model
    assert doc["key"] == scene3d.scene_key(doc)
    assert doc["labels"] == ["A", "B", "C"]
    drawn = [g for g in range(model.ngeom) if model.geom_group[g] <= 2
             and model.geom_rgba[g][3] > 0]
    assert len(doc["geoms"]) == len(drawn)
    assert not any(g["rgba"][3] == 0 for g in doc["geoms"])  # no invisible (collision) geom
    meshes = [g for g in doc["geoms"] if g["type"] == "mesh"]
    assert len(meshes) >= 10  # the Panda's links and hand
    mesh = doc["meshes"][meshes[0]["mesh"]]
    vertices = np.frombuffer(base64.b64decode(mesh["vertices"]), "<u2").reshape(-1, 3)
    real = vertices * np.array(mesh["scale"]) + np.array(mesh["offset"])
    geom = drawn[[g["type"] for g in doc["geoms"]].index("mesh")]
    first = int(model.mesh_vertadr[int(model.geom_dataid[geom])])
    assert np.allclose(real[0], model.mesh_vert[first], atol=1e-5)  # 16 bits over the box
    assert len(json.dumps(doc)) < 3_000_000


def test_the_camera_holds_the_supports_and_both_agents():
    scene = scenes._GraphScene(scenario_graph("wheel"))
    cam = json.loads(scene.camera(None, 0))
    eye, target = np.array(cam["eye"]), np.array(cam["target"])
    forward = (target - eye) / np.linalg.norm(target - eye)
    for point in (*cam["seats"], *np.array(scene.poses(None, 0)).reshape(-1, 7)[:, :3]):
        rel = np.asarray(point) - eye
        angle = np.degrees(np.arccos(rel @ forward / np.linalg.norm(rel)))
        assert angle < cam["fovy"] * 1.5 / 2 * 1.2  # inside the (widest) field of view
    assert len(cam["labels"]) == len(cam["seats"]) == scenario_graph("wheel").n_intentions
