"""``noisybolt classifiers collect|train|report`` on a tiny Breakout dataset."""

from __future__ import annotations

import json
from collections.abc import Sequence

from noisybolt.cli import COMMAND_MODULES, main
from noisybolt.perception.classifier import load_classifier
from noisybolt.perception.dataset import load_dataset


def run(argv: Sequence[str]) -> int:
    return main(list(argv))


def test_registered():
    assert "noisybolt.cli.classifiers" in COMMAND_MODULES


def test_collect_train_report(tmp_path, capsys):
    out = tmp_path / "run"
    tiny = ["--world-arg", "camera_size=24", "--num-envs", "4", "--quiet"]
    assert (
        run(
            [
                "classifiers",
                "collect",
                "--world",
                "breakout",
                "--samples",
                "40",
                "--out",
                str(out),
                *tiny,
            ]
        )
        == 0
    )
    data = load_dataset(out / "dataset.npz")
    assert len(data) == 40 and data.images.shape[1:] == (24, 24, 3)
    assert (
        run(
            [
                "classifiers",
                "train",
                "--out",
                str(out),
                "--epochs",
                "2",
                "--quiet",
                "--channels",
                "4,8",
            ]
        )
        == 0
    )
    detector = load_classifier(
        out / "classifier.safetensors", fluent_names=data.fluent_names, camera_spec=data.camera_spec
    )
    assert detector.config.channels == (4, 8)
    assert len(json.loads((out / "metrics.json").read_text())) == 2
    assert run(["classifiers", "report", "--out", str(out), "--samples", "16", *tiny]) == 0
    printed = capsys.readouterr().out
    assert "brick_clear_left" in printed and "AUROC" in printed
    report = json.loads((out / "report.json").read_text())
    assert report["fluents"][0]["name"] == "brick_clear_left"
    assert report["source"]["seed"] != 0  # a fresh test set, not the training data
    config = json.loads((out / "config.json").read_text())
    assert set(config) == {"collect", "train", "report"}
    assert config["collect"]["samples"] == 40
    assert config["collect"]["world_args"] == {"camera_size": 24}
    assert config["train"]["training"]["epochs"] == 2
    commands = (out / "command.txt").read_text().splitlines()
    assert [c.split()[2] for c in commands] == ["collect", "train", "report"]
    assert "--world breakout" in commands[0] and "camera_size=24" in commands[0]
    # the report against the training set itself, from a recorded dataset
    assert (
        run(
            [
                "classifiers",
                "report",
                "--out",
                str(out),
                "--dataset",
                str(out / "dataset.npz"),
                "--quiet",
            ]
        )
        == 0
    )


def test_unknown_world_is_a_named_error(tmp_path, capsys):
    code = run(["classifiers", "collect", "--world", "pong", "--out", str(tmp_path), "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    assert "pong" in err and "breakout" in err


def test_classifier_for_another_camera_is_refused(tmp_path, capsys):
    out = tmp_path / "run"
    base = ["--num-envs", "2", "--quiet", "--out", str(out)]
    assert (
        run(
            [
                "classifiers",
                "collect",
                "--world",
                "breakout",
                "--samples",
                "20",
                "--world-arg",
                "camera_size=16",
                *base,
            ]
        )
        == 0
    )
    assert run(["classifiers", "train", "--epochs", "1", "--channels", "2", *base[2:]]) == 0
    capsys.readouterr()
    code = run(
        [
            "classifiers",
            "report",
            "--world",
            "breakout",
            "--world-arg",
            "camera_size=20",
            "--samples",
            "8",
            *base,
        ]
    )
    assert code == 2
    assert "camera height differs" in capsys.readouterr().err


def test_corrupt_dataset_is_a_clear_error(tmp_path, capsys):
    (tmp_path / "dataset.npz").write_bytes(b"PK\x03\x04 broken")
    assert run(["classifiers", "train", "--out", str(tmp_path), "--quiet"]) == 2
    assert "corrupt" in capsys.readouterr().err


def test_train_without_a_dataset_says_to_collect_one(tmp_path, capsys):
    assert run(["classifiers", "train", "--out", str(tmp_path / "none"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"no dataset at {tmp_path / 'none' / 'dataset.npz'}" in err
    assert "noisybolt classifiers collect" in err and "Traceback" not in err


def test_gridworld_with_regional_noise(tmp_path, capsys):
    out = tmp_path / "grid"
    common = ["--out", str(out), "--quiet"]
    assert (
        run(
            [
                "classifiers",
                "collect",
                "--world",
                "gridworld",
                "--noise",
                "regional",
                "--samples",
                "120",
                "--num-envs",
                "8",
                *common,
            ]
        )
        == 0
    )
    assert run(["classifiers", "train", "--epochs", "1", *common]) == 0
    assert run(["classifiers", "report", "--samples", "60", *common]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["collect"]["camera_spec"]["noise"]["name"] == "regional"
    assert len(config["collect"]["fluent_names"]) == 7
    assert "bottom_left_corner" in capsys.readouterr().out
    # the same classifier on the clean camera is refused unless asked for on purpose
    assert run(["classifiers", "report", "--noise", "none", "--samples", "30", *common]) == 2
    assert "camera noise differs" in capsys.readouterr().err
    assert (
        run(
            [
                "classifiers",
                "report",
                "--noise",
                "none",
                "--samples",
                "30",
                "--ignore-noise",
                *common,
            ]
        )
        == 0
    )


def test_unknown_noise_is_a_named_error(tmp_path, capsys):
    code = run(
        [
            "classifiers",
            "collect",
            "--world",
            "gridworld",
            "--noise",
            "pink",
            "--out",
            str(tmp_path),
            "--quiet",
        ]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "pink" in err and "regional" in err and "gaussian" in err
