"""Reports: Markdown with relative links, self-contained HTML, runs and sweeps, bad paths."""

from __future__ import annotations

import base64
import doctest
import json
import re
from pathlib import Path
from typing import Any

import imageio.v3 as iio
import numpy as np
import pytest

from noisybolt.cli import main
from noisybolt.errors import ConfigError
from noisybolt.experiments import report as report_module
from noisybolt.experiments.plotting import plot_learning_curves
from noisybolt.experiments.report import run_report, write_report
from noisybolt.experiments.reporting import (
    Code,
    Heading,
    Image,
    Link,
    Table,
    Text,
    render_html,
    render_markdown,
)
from noisybolt.experiments.sweeps import SweepConfig, run_sweep

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def sweep_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished trial with a GIF and a heat-map saved beside it, and a failed trial."""
    import noisybolt.runs.training as training

    real_train = training.train

    def train_or_crash(config: Any, run_dir: Any, **kwargs: Any) -> Any:
        if config.algorithm.name == "a2c":
            raise ValueError("no A2C today")
        return real_train(config, run_dir, **kwargs)

    sweep = SweepConfig.from_dict(
        {
            "name": "reported",
            "base": {
                "detector": {"kind": "oracle"},
                "frames": 1024,
                "eval_freq": 512,
                "eval_episodes": 4,
                "checkpoint_freq": 0,
                "specs": ["edge"],
            },
            "rows": [
                {"name": "ppo", "algo": "ppo", "hyperparams": {"n_steps": 64}},
                {"name": "a2c", "algo": "a2c"},
            ],
            "retries": 0,
        }
    )
    out = tmp_path_factory.mktemp("report") / "sweep"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(training, "train", train_or_crash)
        run_sweep(sweep, out, argv=["noisybolt", "sweep", "reported.yaml"], log=lambda _: None)
    run = out / "trials" / "ppo" / "seed-0"
    frames = np.zeros((3, 8, 8, 3), dtype=np.uint8)
    frames[1, 2:4, 2:4] = 255
    iio.imwrite(run / "episode.gif", frames, extension=".gif")
    plot_learning_curves(
        {"x": [{"frames": 1, "env_return_mean": 0.0, "success_rate": 0.0}]},
        run / "heatmap.png",
        title="stand-in heat-map",
    )
    return out


def test_markdown_and_html_render_the_same_blocks(tmp_path: Path) -> None:
    (tmp_path / "pic.png").write_bytes(PNG + b"fake")
    blocks = [
        Heading("Title"),
        Text("see `code` and **bold** and [that](other/report.md)"),
        Table(("a", "b|c"), (("1", Link("run", "trials/x/report")),)),
        Code('{"k": "<v>"}', "json"),
        Image("pic.png", "a picture"),
        Image("missing.png"),
    ]
    markdown = render_markdown(blocks)
    assert "| a | b\\|c |" in markdown
    assert "[run](trials/x/report.md)" in markdown
    assert "![a picture](pic.png)" in markdown
    assert '```json\n{"k": "<v>"}\n```' in markdown
    page = render_html(blocks, base_dir=tmp_path, title="T")
    assert "<code>code</code>" in page and "<strong>bold</strong>" in page
    assert '<a href="other/report.html">that</a>' in page
    assert '<a href="trials/x/report.html">run</a>' in page
    assert "&lt;v&gt;" in page  # escaped
    encoded = base64.b64encode(PNG + b"fake").decode()
    assert f'src="data:image/png;base64,{encoded}"' in page
    assert "missing picture: missing.png" in page


def test_run_report_holds_config_command_evaluation_curves_and_pictures(sweep_dir: Path) -> None:
    run = sweep_dir / "trials" / "ppo" / "seed-0"
    files = run_report(run)
    markdown = files.markdown.read_text()
    assert markdown.startswith("# Run seed-0")
    assert "Command: `noisybolt sweep reported.yaml`" in markdown
    assert "## Final evaluation" in markdown and "| compliance [edge] |" in markdown
    assert "![learning curves](curves.png)" in markdown
    assert "![episode](episode.gif)" in markdown and "![heatmap](heatmap.png)" in markdown
    assert "## Evaluations during training" in markdown and "| 1,024 |" in markdown
    assert '"schema": 2' in markdown and '"name": "ppo"' in markdown  # config.json
    assert (run / "curves.png").read_bytes()[:8] == PNG
    page = files.html.read_text()
    # Self-contained: every picture embedded, nothing fetched from elsewhere.
    assert "data:image/gif;base64," in page and page.count("data:image/png;base64,") == 2
    assert not re.search(r'src="(?!data:)', page)


def test_run_report_shows_the_evaluations_under_other_settings(
    sweep_dir: Path, tmp_path: Path
) -> None:
    import shutil

    run = tmp_path / "seed-0"
    shutil.copytree(sweep_dir / "trials" / "ppo" / "seed-0", run)
    own = json.loads((run / "summary.json").read_text())["final"]
    noisy = {**own, "overrides": {"world.kwargs.noise": "regional"}, "episodes": 3}
    (run / "evaluation-0a1b2c3d.json").write_text(json.dumps(noisy))
    markdown = run_report(run).markdown.read_text()
    assert '### Evaluated with {"world.kwargs.noise": "regional"}' in markdown
    assert "`evaluation-0a1b2c3d.json`: 3 episodes" in markdown


def test_sweep_report_links_every_trial_and_lists_failures(sweep_dir: Path) -> None:
    files = write_report(sweep_dir)
    markdown = files.markdown.read_text()
    assert "2 trials: 1 done, 1 failed, 0 interrupted (the sweep's command resumes" in markdown
    assert "0 not started." in markdown
    assert "| ppo | ppo | edge | 1/1 | 0 |" in markdown
    assert "| a2c | a2c | edge | 0/1 | 1 |" in markdown
    assert "![learning curves of ppo](curves/ppo.png)" in markdown
    assert "[ppo/seed-0](trials/ppo/seed-0/report.md)" in markdown
    assert "`a2c/seed-0`: ValueError: no A2C today" in markdown
    assert (sweep_dir / "trials" / "ppo" / "seed-0" / "report.html").exists()
    # The failed trial's run report shows its traceback.
    failed = (sweep_dir / "trials" / "a2c" / "seed-0" / "report.md").read_text()
    assert "## Failed attempts" in failed and "Traceback" in failed
    page = files.html.read_text()
    assert '<a href="trials/ppo/seed-0/report.html">' in page


def test_report_command(
    sweep_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["report", str(sweep_dir / "trials" / "ppo" / "seed-0"), "--no-html"]) == 0
    assert "markdown:" in capsys.readouterr().out
    assert main(["report", str(tmp_path)]) == 2
    assert "holds neither a run" in capsys.readouterr().err
    assert main(["report", str(tmp_path / "typo")]) == 2
    assert "typo does not exist: give the directory" in capsys.readouterr().err
    # a `noisybolt classifiers` directory has a config.json (per stage) and a metrics.json
    # (per epoch) too: named as what it is, not read as a run with corrupt files
    classifiers = tmp_path / "c"
    classifiers.mkdir()
    (classifiers / "config.json").write_text(json.dumps({"collect": {}, "train": {}}))
    (classifiers / "metrics.json").write_text(json.dumps([{"epoch": 1, "train_loss": 0.5}]))
    assert main(["report", str(classifiers)]) == 2
    err = capsys.readouterr().err
    assert "holds fluent classifiers (noisybolt classifiers: collect, train)" in err
    assert f"noisybolt classifiers report --out {classifiers}" in err and "corrupt" not in err
    with pytest.raises(ConfigError, match="no evaluations to plot"):
        plot_learning_curves({"seed 0": []}, tmp_path / "x.png", title="empty")


def test_module_doctests_pass() -> None:
    from noisybolt.experiments.reporting import blocks, numbers, render

    for module in (report_module, render, numbers, blocks):
        assert doctest.testmod(module).failed == 0


def test_report_regenerates_the_committed_table1_byte_for_byte_from_its_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    committed = Path(__file__).resolve().parents[2] / "results" / "table1"
    folder = tmp_path / "table1"
    folder.mkdir()
    shutil.copy(committed / "table1.json", folder / "table1.json")  # the JSON alone
    assert main(["report", str(folder)]) == 0
    assert (folder / "table1.md").read_bytes() == (committed / "table1.md").read_bytes()
    assert (folder / "table1.csv").read_bytes() == (committed / "table1.csv").read_bytes()
    report = (folder / "report.md").read_text()
    assert "## Table 1, reproduced" in report and "| `G(on_edge)` | PPO | 89.5 | 94 |" in report
    assert "html:" in capsys.readouterr().out


def test_a_result_table_renders_the_same_cells_in_every_format(tmp_path: Path) -> None:
    from noisybolt.experiments.reporting import render_csv, render_text

    table = Table(
        ("group", "R_π"),
        (("a|b", "1.00 ± 0.50"),),
        data_header=("group", "r_pi_mean", "r_pi_std"),
        data_rows=(("a|b", 1.0, 0.5),),
    )
    assert render_markdown([table]) == "| group | R_π |\n|---|---|\n| a\\|b | 1.00 ± 0.50 |\n"
    assert render_csv(table) == "group,r_pi_mean,r_pi_std\na|b,1.0,0.5\n"
    assert render_text([table]) == "a|b  1.00 ± 0.50"
    assert "<td>1.00 ± 0.50</td>" in render_html([table], base_dir=tmp_path, title="t")
    assert render_csv(Table(("x",), (("1",),))) == "x\n1\n"
