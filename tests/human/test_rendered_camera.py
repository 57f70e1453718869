"""The rendered depth camera (issue 15 item 1; thesis Ch. 9): its depth image agrees with the
analytic camera on a simple scene, shows self-occlusion, and has the failure modes of a
skeleton tracker (jitter growing with depth, jumps to a wrong surface)."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from hrc_drake.human.body import BodyModel
from hrc_drake.human.camera import (
    DepthCameraModel,
    RenderedCameraModel,
    look_at_rotation,
    point_surface_radius,
)
from hrc_drake.messages import R_ELBOW, R_WRIST, DepthFrame

CAMERA, TARGET = np.array([-0.2, 0.0, 1.8]), np.array([1.0, 0.0, 1.0])
BOX_CENTER, BOX_SIZE = np.array([0.5, 0.1, 1.3]), np.array([0.1, 0.4, 0.3])


def _scene(points, box=True, human_points=None, **model_args):
    """A SceneGraph with the box occluder (and optionally a body through `human_points`), the
    rendered camera measuring `points` (8, 3); returns (frame, depth frame, model) of the tick at 0."""
    from pydrake.geometry import Box, GeometryInstance, SceneGraph
    from pydrake.math import RigidTransform

    from hrc_drake.cell.systems import (
        HumanCapsules,
        HumanGeometry,
        perception_properties,
        use_coarse_perception_meshes,
    )
    from hrc_drake.human.systems import add_rendered_camera

    builder = DiagramBuilder()
    scene_graph = builder.AddSystem(SceneGraph())
    if box:
        source = scene_graph.RegisterSource("scene")
        instance = GeometryInstance(RigidTransform(BOX_CENTER), Box(*BOX_SIZE), "box")
        instance.set_perception_properties(perception_properties([0.5, 0.5, 0.5, 1.0]))
        scene_graph.RegisterAnchoredGeometry(source, instance)
    body = BodyModel()
    if human_points is not None:
        capsules = builder.AddSystem(HumanCapsules(body, source="points"))
        geometry = builder.AddSystem(HumanGeometry(scene_graph, body))
        builder.Connect(capsules.GetOutputPort("capsules"), geometry.get_input_port())
        builder.Connect(geometry.get_output_port(), scene_graph.get_source_pose_port(geometry.source_id))
    model = RenderedCameraModel(CAMERA, TARGET, **model_args)
    camera = add_rendered_camera(builder, scene_graph, model, rng_seed=1)
    use_coarse_perception_meshes(scene_graph)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    camera_context = camera.GetMyContextFromRoot(context)
    camera.GetInputPort("skeleton").FixValue(camera_context, np.asarray(points, float).ravel())
    camera.GetInputPort("gaze").FixValue(camera_context, np.array([-1.0, 0.0, 0.0]))
    if human_points is not None:
        capsules.get_input_port().FixValue(capsules.GetMyContextFromRoot(context),
                                           np.asarray(human_points, float).ravel())
    simulator = Simulator(diagram, context)
    simulator.Initialize()
    simulator.AdvanceTo(0.01)  # the camera's tick at t = 0
    return (camera.GetOutputPort("skeleton_frame").Eval(camera_context),
            camera.GetOutputPort("depth_frame").Eval(camera_context), model)


def _clear_of_edges(points, clearance=0.04):
    """Points whose line of sight is at least `clearance` from the box's silhouette: the box
    grown and shrunk by it gives the same answer."""
    grown = DepthCameraModel(CAMERA, TARGET, [(BOX_CENTER, BOX_SIZE)], margin=clearance)
    shrunk = DepthCameraModel(CAMERA, TARGET, [(BOX_CENTER, BOX_SIZE - 2 * clearance)])
    outside = np.all(np.abs(points - BOX_CENTER) > 0.5 * BOX_SIZE + clearance, axis=1)
    return (grown.is_occluded(points) == shrunk.is_occluded(points)) & outside


def test_look_at_rotation_is_drakes_camera_frame():
    R = look_at_rotation([0, 0, 0], [2, 0, 0])
    np.testing.assert_allclose(R, [[0, 0, 1], [-1, 0, 0], [0, -1, 0]], atol=1e-12)
    down = look_at_rotation([0, 0, 2], [0, 0, 0])  # straight down: still a rotation
    np.testing.assert_allclose(down.T @ down, np.eye(3), atol=1e-12)


def test_rendered_and_analytic_cameras_hide_the_same_points():
    """A box between the camera and a grid of points: the rendered image and the analytic
    slab test flag the same points (points at grazing edges left out)."""
    rng = np.random.default_rng(0)
    grid = rng.uniform([0.2, -0.5, 0.7], [1.6, 0.6, 1.6], size=(4000, 3))
    model = RenderedCameraModel(CAMERA, TARGET)
    # inside the rendered field of view (narrower than the analytic cone) with a margin
    u, v, z, inside = DepthFrame(depth=np.zeros((model.height, model.width)), X_CW=model.X_CW,
                                 intrinsics=(model.fx, model.fy, model.cx, model.cy)).project(grid)
    in_view = inside & (u > 3) & (u < model.width - 4) & (v > 3) & (v < model.height - 4) & (z > 0.6)
    grid = grid[in_view & _clear_of_edges(grid)]
    analytic = DepthCameraModel(CAMERA, TARGET, [(BOX_CENTER, BOX_SIZE)])
    _, depth, _ = _scene(grid[:8], depth_tolerance=0.0)
    rendered_hidden = depth.is_hidden(grid, tolerance=0.0)
    analytic_hidden = analytic.is_hidden(grid)
    assert analytic_hidden.sum() > 80 and (~analytic_hidden).sum() > 80  # both kinds are tested
    np.testing.assert_array_equal(rendered_hidden, analytic_hidden)
    # the camera's own flags for its 8 points are the same test
    np.testing.assert_array_equal(depth.hidden, analytic.is_hidden(grid[:8]))


def test_the_depth_image_measures_the_box_face():
    """The image's depth towards the box centre is the depth where that sight line meets the
    box's front face (x = centre - half size)."""
    _, depth, model = _scene(np.tile(BOX_CENTER, (8, 1)))
    u, v, _, inside = depth.project(BOX_CENTER)
    sight = BOX_CENTER - CAMERA
    face = CAMERA + sight * (BOX_CENTER[0] - 0.5 * BOX_SIZE[0] - CAMERA[0]) / sight[0]
    assert inside
    assert depth.depth[v, u] == pytest.approx((face - CAMERA) @ model.R_WC[:, 2], abs=0.005)


def _hand_behind_the_back():
    """The operator facing the camera, right arm reaching behind the back: the right wrist and
    elbow are behind the torso from the camera's view."""
    body = BodyModel()
    points = body.points(body.rest_q((1.05, 0.0), np.pi))
    thorax = points[0]
    points[R_ELBOW] = thorax + [0.18, -0.08, -0.2]
    points[R_WRIST] = thorax + [0.25, -0.02, -0.35]
    return body, points


def test_self_occlusion_a_hand_behind_the_torso_is_untracked():
    body, points = _hand_behind_the_back()
    frame, depth, _ = _scene(points, box=False, human_points=points, noise_std=0.0,
                             wrong_surface_probability=0.0,
                             point_radius=point_surface_radius(body.capsule_radius))
    assert not frame.tracked[R_WRIST] and depth.hidden[R_WRIST]
    assert np.all(np.isnan(frame.points[R_WRIST]))
    # the points on the body's front are seen through their own surface
    assert frame.tracked[[0, 1, 2, 3, 4, 6]].all()
    np.testing.assert_allclose(frame.points[frame.tracked], points[frame.tracked])
    # the analytic camera has no body to hide behind
    assert not DepthCameraModel(CAMERA, TARGET).is_hidden(points[R_WRIST])


def _empty_image(model, depth=np.inf):
    return np.full((model.height, model.width), depth, dtype=np.float32)


def test_jitter_grows_with_depth():
    """Seeded: the spread of a point at 3 m is (3 / 1) ** 2 that of a point at 1 m."""
    model = RenderedCameraModel([0, 0, 0], [1, 0, 0], noise_std=0.004, jitter_exponent=2.0)
    points = np.array([[1.0, 0.0, 0.0]] * 4 + [[3.0, 0.0, 0.0]] * 4)
    image = _empty_image(model)
    frames = [model.measure(0.0, points, [1, 0, 0], image, np.random.default_rng([7, k]))[0]
              for k in range(300)]
    errors = np.array([f.points - points for f in frames])  # (frames, 8, 3)
    near, far = errors[:, :4].std(), errors[:, 4:].std()
    assert near == pytest.approx(0.004, rel=0.1)
    assert far == pytest.approx(9 * 0.004, rel=0.1)
    np.testing.assert_allclose(model.jitter_std([1.0, 2.0]), [0.004, 0.016])


def test_wrong_surface_jumps_appear_at_their_probability():
    """Behind a wall every point is hidden; a fraction ~ p stays tracked on the wall's surface."""
    model = RenderedCameraModel([0, 0, 0], [1, 0, 0], noise_std=0.0, wrong_surface_probability=0.2)
    points = np.array([[2.0, y, z] for y in (-0.3, 0.0, 0.3, 0.5) for z in (-0.2, 0.2)])
    wall = _empty_image(model, 1.0)
    frames = [model.measure(0.0, points, [1, 0, 0], wall, np.random.default_rng([3, k])) for k in range(400)]
    tracked = np.array([f.tracked for f, _ in frames])
    assert all(d.hidden.all() for _, d in frames)
    assert tracked.mean() == pytest.approx(0.2, abs=0.03)
    np.testing.assert_array_equal(tracked, [d.wrong_surface for _, d in frames])
    jumped = np.concatenate([f.points[f.tracked] for f, _ in frames])
    np.testing.assert_allclose(jumped[:, 0], 1.0, atol=1e-5)  # on the wall (depth along x)
    # near its own pixel: within wrong_surface_pixels pixels of where its sight line meets the wall
    on_wall = np.repeat(points[None, :, 1:] / points[None, :, :1], 400, 0)[tracked]
    assert np.abs(jumped[:, 1:] - on_wall).max() <= 3.5 / min(model.fx, model.fy)
    # a point out of the image has no surface in front of it to jump to
    out = points.copy()
    out[:, 0] = -1.0
    assert not any(model.measure(0.0, out, [1, 0, 0], wall, np.random.default_rng(k))[0].tracked.any()
                   for k in range(50))


def test_same_seed_same_frame_and_range_limits():
    model = RenderedCameraModel([0, 0, 0], [1, 0, 0], wrong_surface_probability=0.5)
    points = np.array([[2.0, 0.1 * k - 0.4, 0.0] for k in range(8)])
    points[0] = [0.3, 0.0, 0.0]  # nearer than min_depth
    points[1] = [5.0, 0.0, 0.0]  # farther than max_depth
    image = _empty_image(model, 1.5)
    a, da = model.measure(0.0, points, [1, 0, 0], image, np.random.default_rng(5))
    b, db = model.measure(0.0, points, [1, 0, 0], image, np.random.default_rng(5))
    np.testing.assert_array_equal(a.points, b.points)
    np.testing.assert_array_equal(da.wrong_surface, db.wrong_surface)
    assert da.hidden[:2].all()
    free = model.measure(0.0, points, [1, 0, 0], _empty_image(model), np.random.default_rng(5))[0]
    assert not free.tracked[:2].any() and free.tracked[2:].all()


def test_an_empty_depth_frame_hides_everything():
    assert DepthFrame().is_hidden(np.zeros((5, 3))).all()


@pytest.mark.parametrize("kwargs", [dict(width=0), dict(fov_x=180.0), dict(min_depth=2.0, max_depth=1.0),
                                    dict(wrong_surface_probability=1.5), dict(noise_std=-1.0)])
def test_bad_model_arguments_raise(kwargs):
    with pytest.raises(ValueError):
        RenderedCameraModel(CAMERA, TARGET, **kwargs)
