"""Benchmark: how soon the 3D view (app/viewer.py) shows a kitchen scene in headless Chromium.

Each trial starts a fresh viewer process from one source tree (``--tree``, default this
checkout; give two to compare them, e.g. an export of an older commit), has it show the scene
(``RunViewer.show`` with no events: the platforms, the blocks and the PR2), opens the viewer's
page in a fresh Chromium profile (cold cache) and records, from inside the page, every
animation frame's WebGL draw calls and triangles in the scene's canvas for 25 s. viser keeps
redrawing now and then; the frame it draws most in the last seconds is the settled scene, and
the first frame is the first one that draws at least 99% of its triangles. (Some seconds in,
viser draws one frame with a few invisible extras, about 250 triangles in 21 calls in both trees,
then the settled frame again: the largest frame is not the reference.) Trials of the trees
alternate (A B, B A, ...), so a paired ratio compares trials run side by side.

    mkdir /tmp/base && git archive 15f517c | tar -x -C /tmp/base   # the boxes, before meshes
    .venv/bin/python benchmarks/viewer_first_frame.py --scene kitchen-8 --repeats 6 \\
        --tree /tmp/base --tree .

Printed per tree: the median first frame (ms since navigation), the scene build in the viewer
process (``show``), the settled frame's triangles and draw calls; then the paired ratios of the
first frame, last tree over first, one per pair of trials.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from playwright.sync_api import sync_playwright

from app.browser import CHROMIUM_ARGS, require_chromium

ROOT = Path(__file__).resolve().parent.parent
COMPLETE = 0.99  # a frame drawing this share of the settled triangles shows the whole scene
OBSERVE_S = 25.0  # frames are recorded this long after navigation (the scene is up by ~5 s)
SETTLED_S = 6.0  # the most common frame of the last seconds observed is the settled scene
SCENE = 100  # frames drawing fewer triangles are a cleared canvas, not the scene

# Runs inside the viewer process: show the scene, say where, wait until stdin closes.
VIEWER = """
import json, sys, time
from app.viewer import RunViewer
viewer = RunViewer(port=0)
start = time.perf_counter()
viewer.show(sys.argv[1], int(sys.argv[2]), [], None)
print(json.dumps({"url": viewer.url, "show_s": time.perf_counter() - start}), flush=True)
sys.stdin.read()
viewer.close()
"""

# Counts triangles and draw calls per animation frame and WebGL context (the page has a small
# second one, the axes in the corner), before the page's own scripts run.
FRAME_COUNTER = """
(() => {
  const w = { ids: new WeakMap(), next: 0, now: {}, frames: [] };
  window.__frames = w;
  const count = (gl, mode, vertices) => {
    if (!w.ids.has(gl)) w.ids.set(gl, w.next++);
    const id = w.ids.get(gl);
    const c = (w.now[id] = w.now[id] || { tri: 0, calls: 0 });
    if (mode === 4) c.tri += vertices / 3;
    c.calls += 1;
  };
  const wrap = (proto) => {
    const de = proto.drawElements, da = proto.drawArrays;
    proto.drawElements = function (mode, n, type, offset) {
      count(this, mode, n);
      return de.call(this, mode, n, type, offset);
    };
    proto.drawArrays = function (mode, first, n) {
      count(this, mode, n);
      return da.call(this, mode, first, n);
    };
    if (proto.drawElementsInstanced) {
      const dei = proto.drawElementsInstanced, dai = proto.drawArraysInstanced;
      proto.drawElementsInstanced = function (mode, n, type, offset, k) {
        count(this, mode, n * k);
        return dei.call(this, mode, n, type, offset, k);
      };
      proto.drawArraysInstanced = function (mode, first, n, k) {
        count(this, mode, n * k);
        return dai.call(this, mode, first, n, k);
      };
    }
  };
  wrap(WebGLRenderingContext.prototype);
  wrap(WebGL2RenderingContext.prototype);
  const tick = () => {
    for (const [id, c] of Object.entries(w.now)) {
      w.frames.push([performance.now(), Number(id), c.tri, c.calls]);
    }
    w.now = {};
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
})();
"""


@dataclass(frozen=True)
class Trial:
    tree: str
    first_frame_ms: float  # navigation start -> first frame with the whole scene
    show_s: float  # the viewer process building the scene
    triangles: int  # drawn in the settled page's frame
    calls: int  # draw calls of that frame
    load: float  # 1-minute load average at the start of the trial


def run_trial(pw: Any, tree: Path, scene: str, seed: int, width: int, height: int) -> Trial:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    viewer = subprocess.Popen(
        [sys.executable, "-c", VIEWER, scene, str(seed)],
        cwd=tree,
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    load = os.getloadavg()[0]
    try:
        assert viewer.stdout is not None
        line = viewer.stdout.readline()
        while line and not line.startswith("{"):  # pybullet says its build time on stdout
            line = viewer.stdout.readline()
        if not line:
            raise RuntimeError(f"the viewer in {tree} exited with {viewer.wait()}")
        ready = json.loads(line)
        with tempfile.TemporaryDirectory() as profile:
            browser = pw.chromium.launch_persistent_context(
                profile,
                executable_path=require_chromium(),
                args=CHROMIUM_ARGS,
                viewport={"width": width, "height": height},
            )
            try:
                browser.add_init_script(FRAME_COUNTER)
                page = browser.new_page()
                page.goto(ready["url"])
                frames = _settled_frames(page)
            finally:
                browser.close()
    finally:
        assert viewer.stdin is not None
        viewer.stdin.close()
        viewer.wait(30)
    _, settled, calls = frames[-1]
    first = next(f for f in frames if f[1] >= COMPLETE * settled)
    return Trial(str(tree), first[0], float(ready["show_s"]), int(settled), calls, load)


def _settled_frames(page: Any) -> list[tuple[float, float, int]]:
    """The scene's frames (ms since navigation, triangles, draw calls): those of the WebGL
    context that drew the most triangles, with more than SCENE triangles (not a cleared canvas),
    OBSERVE_S seconds after navigation; the last is the settled scene (the most common of the
    last SETTLED_S seconds' frames, which viser redraws now and then)."""
    while float(page.evaluate("performance.now()")) < OBSERVE_S * 1000:
        time.sleep(0.5)
    frames = page.evaluate("window.__frames.frames")
    if not frames:
        raise RuntimeError(f"the page drew nothing in {OBSERVE_S} s")
    main = max(frames, key=lambda f: f[2])[1]
    scene = [
        (float(t), float(tri), int(calls))
        for t, gl, tri, calls in frames
        if gl == main and tri > SCENE
    ]
    recent = [f for f in scene if f[0] >= (OBSERVE_S - SETTLED_S) * 1000] or scene[-1:]
    settled = collections.Counter((tri, calls) for _, tri, calls in recent).most_common(1)[0][0]
    return [*scene, (scene[-1][0], *settled)]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="kitchen-8")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=6, help="trials of each tree")
    parser.add_argument(
        "--tree", type=Path, action="append", help="source tree to run (repeat to compare)"
    )
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=800)
    args = parser.parse_args()
    trees = [t.resolve() for t in (args.tree or [ROOT])]
    trials: list[Trial] = []
    with sync_playwright() as pw:
        for r in range(args.repeats):
            order = trees if r % 2 == 0 else trees[::-1]
            for tree in order:
                trial = run_trial(pw, tree, args.scene, args.seed, args.width, args.height)
                trials.append(trial)
                print(
                    f"  {tree}: first frame {trial.first_frame_ms:.0f} ms, show "
                    f"{trial.show_s:.2f} s, {trial.triangles} triangles in {trial.calls} draw "
                    f"calls (load {trial.load:.1f})",
                    flush=True,
                )
    print(
        f"\n{args.scene} seed {args.seed}, {args.width}x{args.height}, {os.cpu_count()} cores, "
        f"load average {min(t.load for t in trials):.1f}-{max(t.load for t in trials):.1f}"
    )
    by_tree = {str(t): [x for x in trials if x.tree == str(t)] for t in trees}
    print("| tree | first frame ms (median, range) | show s | triangles | draw calls |")
    print("| --- | --- | --- | --- | --- |")
    for tree, rows in by_tree.items():
        ms = [x.first_frame_ms for x in rows]
        print(
            f"| {tree} | {statistics.median(ms):.0f} ({min(ms):.0f}-{max(ms):.0f}) | "
            f"{statistics.median(x.show_s for x in rows):.2f} | {rows[-1].triangles} | "
            f"{rows[-1].calls} |"
        )
    if len(trees) == 2:
        a, b = by_tree[str(trees[0])], by_tree[str(trees[1])]
        ratios = [y.first_frame_ms / x.first_frame_ms for x, y in zip(a, b, strict=True)]
        print(
            f"\nfirst frame, {trees[1].name or trees[1]} / {trees[0].name or trees[0]}, paired: "
            f"median {statistics.median(ratios):.2f} "
            f"({', '.join(f'{r:.2f}' for r in ratios)})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
