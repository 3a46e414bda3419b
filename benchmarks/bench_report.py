"""What ``identification_report`` costs against the ``identify`` call it reports, and how much it weighs.

Two records:

- *moderate*: 2,800 samples of a first-order system with a cubic term (``tests/_report_data.py``'s
  record, seed 1, 4,000 samples of which 70 % estimate), ``identify`` with its defaults, the rest
  as the test record;
- *Silverbox*: ``identify(u, y, dt=dt, n_init=50)`` on the 65,062-sample estimation record (the
  call of ``run all``'s "identified automatically" row), the 40,475-sample ``arrow_full`` test.

Printed per record: identify's and the report's wall and CPU seconds (``time.process_time``), the
report's share of identify's CPU, and the page's size. With ``--screenshots DIR`` the Silverbox
page is also opened in headless Chromium (``chromium`` on the PATH) and two screenshots are saved
(``report_first_screen.png``, ``report_choice.png``); ``--run-page PATH`` adds one of a ``run
all`` page (``DIR/silverbox/report.html``: ``report_silverbox_run.png``). The docs' screenshots
(``docs/_static``) come from here.

Measured (the shared 2-core machine busy with other jobs; CPU seconds)::

    moderate    identify 51.5 s CPU (95.5 s wall), 685 candidates; report 1.16 s CPU (2.2 s wall): 2.3 %; 0.71 MB
    Silverbox   identify 30.4 s CPU (114.1 s wall), 686 candidates; report 1.21 s CPU (3.65 s wall): 4.0 %; 0.90 MB
    Silverbox   identify 33.4 s CPU (304.4 s wall), 686 candidates; report 1.48 s CPU (4.43 s wall): 4.4 %; 0.90 MB
"""

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sindybench import identify
from sindybench.report import identification_report
from sindybench.simulate import simulate

DT = 0.01


def _timed(func):
    wall, cpu = time.perf_counter(), time.process_time()
    result = func()
    return result, time.perf_counter() - wall, time.process_time() - cpu


def _moderate():
    rng = np.random.default_rng(1)
    t = np.arange(4000) * DT
    u = (np.sin(0.9 * t) + 0.8 * np.sin(2.3 * t + 1.0) + 0.5 * np.sin(4.1 * t))[:, None]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] - 0.5 * x[0] ** 3 + 2.0 * u[0]]), [0.0], u, dt=DT,
                 input_hold="linear")
    y = y + 0.002 * rng.standard_normal(y.shape)
    return (u[:2800], y[:2800]), (u[2800:], y[2800:]), DT, {}


def _silverbox(data_home):
    from sindybench.datasets import load_silverbox

    data = load_silverbox(data_home=data_home, download_if_missing=False)
    test = data.test.arrow_full
    return (data.estimation.u, data.estimation.y), (test.u, test.y), float(data.estimation.dt), {"n_init": 50}


def measure(name, estimation, test, dt, settings, path):
    (u, y) = estimation
    model, id_wall, id_cpu = _timed(lambda: identify(u, y, dt=dt, show_progress_bar=False, **settings))
    html, wall, cpu = _timed(lambda: identification_report(model, u, y, test=test, path=path,
                                                           title=f"{name}: sindybench.identify"))
    print(f"{name:10s}  identify {id_cpu:.1f} s CPU ({id_wall:.1f} s wall), "
          f"{len(model.identification_['cv_results']['family'])} candidates; report {cpu:.2f} s CPU ({wall:.2f} s "
          f"wall): {100 * cpu / id_cpu:.1f} %; {len(html.encode()) / 1e6:.2f} MB", flush=True)
    return path


def screenshot(page, png, *, height, hide=()):
    """Screenshot the top of ``page`` (1280 pixels wide), the elements ``hide`` (CSS selectors) hidden first."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        sys.exit("no chromium on the PATH: apt-get install chromium")
    with tempfile.TemporaryDirectory() as tmp:
        text = Path(page).read_text(encoding="utf-8")
        if hide:
            style = ",".join(hide) + "{display:none}"
            text = text.replace("</style>", style + "</style>", 1)
        copy = Path(tmp) / "page.html"
        copy.write_text(text, encoding="utf-8")
        subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--hide-scrollbars",
                        f"--user-data-dir={tmp}/profile", f"--screenshot={png}", f"--window-size=1280,{height}",
                        copy.as_uri()], check=True, capture_output=True, timeout=120)
    print("wrote", png, f"{Path(png).stat().st_size / 1e3:.0f} kB")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-home", default=None, help="benchmark data (default: SINDYBENCH_DATA)")
    parser.add_argument("--out", default=".", help="folder for the pages (default: here)")
    parser.add_argument("--screenshots", default=None, help="folder for the screenshots (e.g. docs/_static)")
    parser.add_argument("--run-page", default=None, help="a run all page to screenshot (DIR/silverbox/report.html)")
    parser.add_argument("--skip-moderate", action="store_true")
    args = parser.parse_args()
    out = Path(args.out)
    if not args.skip_moderate:
        measure("moderate", *_moderate(), out / "report_moderate.html")
    page = measure("Silverbox", *_silverbox(args.data_home), out / "report_silverbox.html")
    if args.screenshots:
        shots = Path(args.screenshots)
        screenshot(page, shots / "report_first_screen.png", height=1100)
        screenshot(page, shots / "report_choice.png", height=1300, hide=("#summary", "#data", "nav"))
        if args.run_page:
            screenshot(args.run_page, shots / "report_silverbox_run.png", height=1500)


if __name__ == "__main__":
    main()
