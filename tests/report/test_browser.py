"""report.html in a real browser: it renders, every figure decodes, and it touches no network.

Runs headless Chromium (``chromium`` or ``chromium-browser`` on PATH; ``.ci/run`` installs it).
Skipped, with the reason shown, where no Chromium is installed.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pandas as pd
import pytest

from hmid.report import Figure, Report, Section, Table, write_report

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None,
    reason="headless Chromium not found on PATH (apt-get install chromium; .ci/run installs it)",
)

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)
NETWORK_SCHEMES = {"http", "https", "ws", "wss", "ftp"}


def chromium(target: Path, workdir: Path, *args: str) -> str:
    """Run Chromium on ``target`` with a fresh profile; returns stdout (the DOM for --dump-dom)."""
    profile = tempfile.mkdtemp(prefix="profile-", dir=workdir)
    command = [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", *args, target.as_uri()]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, check=False)
    assert done.returncode == 0, f"{' '.join(command)} failed:\n{done.stderr[-3000:]}"
    return done.stdout


def dump_dom(page: Path, workdir: Path) -> tuple[str, list[str]]:
    """The DOM after the onload script ran, and the network URLs the page itself requested."""
    net_log = workdir / f"net-{page.stem}.json"
    dom = chromium(
        page,
        workdir,
        "--virtual-time-budget=5000",
        f"--log-net-log={net_log}",
        "--net-log-capture-mode=Default",
        "--dump-dom",
    )
    return dom, page_requests(net_log)


def page_requests(net_log: Path) -> list[str]:
    """http/https/ws URLs requested on behalf of the page, from a Chromium net log.

    Chromium itself contacts Google (component updates, network time, account checks) whatever
    the flags; those requests have no initiator. A page's own requests (images, scripts, fetch,
    websockets) carry the page's origin as initiator and ``file://`` in the isolation key. A
    request whose origin cannot be told is counted as the page's, to be safe.
    """
    log = json.loads(net_log.read_text(encoding="utf-8"))
    event_names = {number: name for name, number in log["constants"]["logEventTypes"].items()}
    url_request = log["constants"]["logSourceType"]["URL_REQUEST"]
    urls: dict[int, str] = {}
    from_page: dict[int, bool] = {}
    for event in log["events"]:
        if event["source"]["type"] != url_request:
            continue
        source, params = event["source"]["id"], event.get("params") or {}
        if isinstance(params.get("url"), str):
            urls.setdefault(source, params["url"])
        if event_names.get(event["type"]) == "URL_REQUEST_START_JOB" and "initiator" in params:
            by_page = params["initiator"] != "not an origin" or "file://" in params.get(
                "network_isolation_key", ""
            )
            from_page[source] = from_page.get(source, False) or by_page
    assert log["events"], f"{net_log}: empty net log"
    return sorted(
        url
        for source, url in urls.items()
        if urlsplit(url).scheme in NETWORK_SCHEMES and from_page.get(source, True)
    )


def images_ok(dom: str) -> str:
    """The page script's verdict, e.g. "2/2" (decoded/total); fails if the script did not run."""
    found = re.search(r'<body[^>]*\sdata-images-ok="(\d+/\d+)"', dom)
    check = re.search(r'<div id="img-check"[^>]*>images decoded: (\d+/\d+)</div>', dom)
    assert found and check, "the image check did not run (no data-images-ok / #img-check)"
    assert found.group(1) == check.group(1)
    return found.group(1)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A run folder with two real matplotlib figures, a table, and the written report."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run = tmp_path_factory.mktemp("run")
    (run / "figures").mkdir()
    t = np.linspace(0.0, 10.0, 300)
    fig, ax = plt.subplots(figsize=(6, 3), dpi=80)
    ax.plot(t, np.sin(t), label="measured")
    ax.plot(t, np.sin(t) + 0.05 * np.cos(7 * t), label="cubic_xvP")
    ax.set(xlabel="t [s]", ylabel="F [N]")
    ax.legend()
    fig.savefig(run / "figures" / "fit.png")
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(4, 3), dpi=80)
    ax.hist(np.random.default_rng(0).normal(size=300), bins=25)
    ax.set(xlabel="residual [N]")
    fig.savefig(run / "figures" / "residuals.png")
    plt.close(fig)

    metrics = pd.DataFrame(
        {"model": ["cubic_xvP", "linear_xvP"], "RMSE [N]": [0.02612, 0.1514], "params": [10, 4]}
    )
    report = Report(
        title="Browser check <script>alert(1)</script>",
        summary=(("best model", "cubic_xvP"), ("held-out RMSE (one-step)", "0.026 N")),
        sections=(
            Section(
                "Model comparison",
                text="Ranked by **held-out** one-step RMSE.\n\n- `cubic_xvP` wins\n- by far",
                tables=(Table(metrics, "Held-out metrics"),),
                figures=(Figure(Path("figures/fit.png"), "Measured and predicted force."),),
            ),
            Section(
                "Residuals",
                figures=(Figure(Path("figures/residuals.png"), "One-step residuals."),),
            ),
        ),
        provenance={"git commit": "0123abcd", "remote": "https://example.org/hmid.git"},
    )
    write_report(report, run)
    return run


def test_screenshot_shows_a_rendered_page(run_dir: Path, tmp_path: Path) -> None:
    import matplotlib.image

    shot = tmp_path / "shot.png"
    chromium(run_dir / "report.html", tmp_path, f"--screenshot={shot}", "--window-size=1200,2000")
    assert shot.is_file() and shot.stat().st_size > 10_000
    pixels = matplotlib.image.imread(shot)[..., :3]
    assert pixels.shape[:2] == (2000, 1200)
    assert pixels.std() > 0.05, "the screenshot is (nearly) one colour"
    rgb = (pixels.reshape(-1, 3) * 255).round().astype(np.uint32)
    colours = np.unique(rgb[:, 0] << 16 | rgb[:, 1] << 8 | rgb[:, 2])
    assert colours.size > 200, "too few colours for text, tables and two plots"


def test_images_decode_and_no_network(run_dir: Path, tmp_path: Path, find_external) -> None:
    page = run_dir / "report.html"
    assert find_external(page.read_text(encoding="utf-8")) == []
    dom, requests = dump_dom(page, tmp_path)
    assert images_ok(dom) == "2/2"
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in dom  # the title is shown, not run
    assert requests == [], f"the page made network requests: {requests}"


def test_checks_catch_a_leaky_page(tmp_path: Path) -> None:
    """Controls: the net-log check sees a page's requests, and the CSP blocks injected ones."""
    leaky = tmp_path / "leaky.html"
    leaky.write_text(
        '<!DOCTYPE html><img src="http://127.0.0.1:9/a.png">'
        '<script src="https://127.0.0.1:9/b.js"></script>'
        '<script>new WebSocket("ws://127.0.0.1:9/c");</script>',
        encoding="utf-8",
    )
    _, requests = dump_dom(leaky, tmp_path)
    assert requests == [
        "http://127.0.0.1:9/a.png",
        "https://127.0.0.1:9/b.js",
        "ws://127.0.0.1:9/c",
    ]


def test_csp_blocks_injected_content_and_the_image_check_notices(
    run_dir: Path, tmp_path: Path
) -> None:
    page = (run_dir / "report.html").read_text(encoding="utf-8")
    injected = page.replace("<main>", '<main><img src="http://127.0.0.1:9/x.png" alt="x">', 1)
    tampered = tmp_path / "tampered.html"
    tampered.write_text(injected, encoding="utf-8")
    dom, requests = dump_dom(tampered, tmp_path)
    assert images_ok(dom) == "2/3"
    assert "1 of 3 figures could not be displayed." in dom
    assert requests == []


#: Measures the page as shown (long tables collapsed): every visible table's wrapper against
#: its width, and the page's height; written into the DOM for --dump-dom to return.
_MEASURE = """<script>
window.addEventListener("load", function () {
  var wide = [];
  document.querySelectorAll(".table-wrap").forEach(function (wrap) {
    if (wrap.closest("details:not([open])")) return;  // shown on request only
    if (wrap.scrollWidth > wrap.clientWidth) {
      var caption = wrap.querySelector("caption");
      wide.push((caption ? caption.textContent : "?") + " " + wrap.scrollWidth + " > " +
                wrap.clientWidth);
    }
  });
  var out = document.createElement("pre");
  out.id = "measure";
  out.textContent = JSON.stringify({wide: wide,
    height: document.documentElement.scrollHeight, width: window.innerWidth});
  document.body.appendChild(out);
});
</script>"""

ROOT = Path(__file__).resolve().parents[2]
SCREEN = (1400, 900)


def measure(page: Path, workdir: Path) -> dict:
    """The page at 1400 x 900 as the reader first sees it: tables wider than their container
    and the height in pixels."""
    text = page.read_text(encoding="utf-8")
    text = re.sub(r'<meta http-equiv="Content-Security-Policy"[^>]*>', "", text)
    copy = workdir / f"measured-{page.parent.name}.html"
    copy.write_text(text.replace("</body>", _MEASURE + "</body>"), encoding="utf-8")
    dom = chromium(copy, workdir, "--virtual-time-budget=5000",
                   f"--window-size={SCREEN[0]},{SCREEN[1]}", "--dump-dom")  # fmt: skip
    found = re.search(r'<pre id="measure">(.*?)</pre>', dom, flags=re.S)
    assert found, "the measuring script did not run"
    return json.loads(found.group(1).replace("&gt;", ">").replace("&amp;", "&"))


@pytest.mark.slow
@pytest.mark.parametrize(
    "config",
    ["demo", "linear-motor",
     pytest.param("pneumatic/o-ring", marks=pytest.mark.shared_data)],
)  # fmt: skip
def test_shipped_reports_fit_the_page(config: str, tmp_path_factory) -> None:
    """Issue 32: on the shipped rigs' reports no table is wider than its container and, with
    long tables collapsed, the page is at most about 8 screens of 1400 x 900."""
    from pipelines.identify import run

    path = ROOT / "configs" / f"{config}.yaml"
    if config.startswith("pneumatic") and not (ROOT.parent / "shared" / "data").is_dir():
        pytest.skip("../shared/data is absent")
    workdir = tmp_path_factory.mktemp("fit")
    run_dir, _ = run(path, results=workdir / "results")
    found = measure(run_dir / "report.html", workdir)
    assert found["wide"] == [], f"tables wider than the page: {found['wide']}"
    assert found["height"] <= 8.5 * SCREEN[1], f"{found['height'] / SCREEN[1]:.1f} screens"
