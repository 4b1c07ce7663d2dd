"""plantlod view: the page holds everything it needs (no network), carries each tree's GLB
byte for byte with its branch count, refuses what is not glTF; and, in headless Chromium,
loads without a console message, draws the trees and moves them."""

from __future__ import annotations

import base64
import html.parser
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import plantlod
from golden_util import ROOT, run_cli

WIND = (9.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def glbs(tmp_path_factory):
    """The stalk and a 2-branch stalk (derived shorter) swaying for 3 s, as .glb files."""
    folder = tmp_path_factory.mktemp("view")
    system = plantlod.read_lsystem(ROOT / "examples" / "stalk8.lsys")
    out = []
    for name, n in (("stalk8.glb", None), ("stalk2.glb", 1)):
        tree = plantlod.derive(system, n)
        angles = plantlod.simulate(tree, wind=WIND, dt=0.01, steps=300, every=2)
        plantlod.export_animation(tree, angles, folder / name)
        out.append((folder / name, tree.n_branches))
    return folder, out


class _Page(html.parser.HTMLParser):
    """The page's elements, attributes and script texts, as an HTML parser sees them."""

    def __init__(self):
        super().__init__()
        self.attributes, self.scripts, self._in = [], [], None

    def handle_starttag(self, tag, attrs):
        self.attributes.append((tag, dict(attrs)))
        self._in = dict(attrs).get("id", "") if tag == "script" else None
        if tag == "script":
            self.scripts.append([self._in, ""])

    def handle_data(self, data):
        if self._in is not None:
            self.scripts[-1][1] += data

    def handle_endtag(self, tag):
        self._in = None


def test_the_page_carries_each_tree_and_needs_no_network(glbs, tmp_path):
    folder, trees = glbs
    page_path = tmp_path / "page.html"
    run_cli("view", *(str(p) for p, _ in trees), "-o", str(page_path), "--wind-direction", "30",
            "--title", "a <b> & c")
    text = page_path.read_text(encoding="utf-8")
    page = _Page()
    page.feed(text)
    # nothing fetched: no element names an outside resource
    for tag, attrs in page.attributes:
        assert not {"src", "href"} & set(attrs), (tag, attrs)
    assert "<title>a &lt;b&gt; &amp; c</title>" in text
    data = json.loads(next(body for ident, body in page.scripts if ident == "plantlod-data"))
    assert data["wind_direction_deg"] == 30.0 and data["title"] == "a <b> & c"
    assert [t["name"] for t in data["trees"]] == ["stalk8.glb", "stalk2.glb"]
    assert [t["branches"] for t in data["trees"]] == [8, 2]
    for entry, (path, _) in zip(data["trees"], trees):
        assert base64.b64decode(entry["glb"]) == path.read_bytes()
    # three.js (its licence in the package) and the viewer are inline, in that order
    bodies = [body for ident, body in page.scripts if not ident]
    assert "var PLANTLOD_THREE=" in bodies[0] and "PLANTLOD_THREE" in bodies[1]
    from importlib import resources

    licence = resources.files("plantlod.export") / "viewer" / "LICENSE-three.txt"
    assert "MIT License" in licence.read_text(encoding="utf-8")


@pytest.mark.parametrize("title", ["<!--<script>", "</script><script>x()</script>", "a&b>c"])
def test_a_title_or_a_name_never_ends_or_opens_an_element_in_the_data(glbs, tmp_path, title):
    """The data block holds no "<" at all, so neither "</script" nor "<!--<script" (which
    made the browser read the viewer's scripts as data: session 34's fuzzing) can act in it,
    and it still reads back as the title and file name given."""
    folder, trees = glbs
    odd = tmp_path / (title.replace("/", "_") + ".glb")
    odd.write_bytes(trees[0][0].read_bytes())
    text = plantlod.write_view([odd], title=title)
    data_text = text.split('id="plantlod-data">', 1)[1].split("</script>", 1)[0]
    assert "<" not in data_text and ">" not in data_text and "&" not in data_text
    data = json.loads(data_text)
    assert data["title"] == title and data["trees"][0]["name"] == odd.name
    page = _Page()
    page.feed(text)
    assert [ident for ident, _ in page.scripts] == ["plantlod-data", "", ""]


def test_each_gltf_list_is_checked_once_whatever_refers_to_it(glbs, monkeypatch):
    """`index` asks for the list it indexes at every reference; each list was checked again
    at each, so `view` took time quadratic in the nodes (abop_1_25: 28 s). Counted, not
    timed: every list is read from the document once."""
    from plantlod.export import gltf_check

    reads: dict[str, int] = {}
    original = gltf_check._Checker._items

    def counted(self, name):
        reads[name] = reads.get(name, 0) + 1
        return original(self, name)

    monkeypatch.setattr(gltf_check._Checker, "_items", counted)
    path, branches = glbs[1][0]
    plantlod.write_view([path], glbs[0] / "once.html")
    assert branches == 8 and reads["nodes"] == 1 and reads["accessors"] == 1
    assert max(reads.values()) == 1


def test_a_gltf_with_its_buffer_inline_is_shown_as_glb(glbs, tmp_path):
    folder, trees = glbs
    tree = plantlod.derive(plantlod.read_lsystem(ROOT / "examples" / "stalk8.lsys"), 1)
    angles = plantlod.simulate(tree, wind=WIND, dt=0.01, steps=50)
    plantlod.export_animation(tree, angles, tmp_path / "t.gltf")
    page = plantlod.write_view([tmp_path / "t.gltf"])
    parser = _Page()
    parser.feed(page)
    data = json.loads(next(body for ident, body in parser.scripts if ident == "plantlod-data"))
    glb = base64.b64decode(data["trees"][0]["glb"])
    assert glb[:4] == b"glTF" and data["trees"][0]["branches"] == 2


def test_what_is_not_gltf_is_exit_2_and_writes_nothing(glbs, tmp_path):
    folder, trees = glbs
    (tmp_path / "bad.glb").write_text("not a model")
    for bad, words in ((tmp_path / "bad.glb", "not a glTF file"),
                       (tmp_path / "missing.glb", "no such file"),
                       (tmp_path, "is a directory")):
        result = run_cli("view", str(trees[0][0]), str(bad), "-o", str(tmp_path / "p.html"),
                         exit_code=2)
        assert words in result.stderr and len(result.stderr.strip().splitlines()) == 1
        assert str(bad) in result.stderr
    assert not (tmp_path / "p.html").exists() and not list(tmp_path.glob(".plantlod-*"))
    run_cli("view", "-o", str(tmp_path / "p.html"), exit_code=2)      # no tree at all


# --- in a browser ---------------------------------------------------------------------------

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
BACKGROUND = np.array([0xEE, 0xF2, 0xF5]) / 255.0       # page.html's background


def _chromium(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--use-angle=swiftshader",
                           "--enable-unsafe-swiftshader", "--enable-logging=stderr", "--v=0",
                           "--virtual-time-budget=8000", "--window-size=800,600", *args],
                          capture_output=True, text=True, timeout=120)


@pytest.mark.browser
@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed: `make test-browser` "
                    "installs Debian's chromium and runs the page in it")
def test_the_page_draws_and_moves_the_trees_in_chromium(glbs, tmp_path):
    import matplotlib.image

    folder, trees = glbs
    page = tmp_path / "page.html"
    plantlod.write_view([p for p, _ in trees], page)
    url = page.resolve().as_uri()
    done = _chromium("--dump-dom", url + "#t=0")
    assert done.returncode == 0, done.stderr[-2000:]
    assert 'data-state="ready"' in done.stdout, done.stdout[-2000:]
    shots = {}
    for t in ("0", "2.5"):
        done = _chromium(f"--screenshot={tmp_path / (t + '.png')}", f"{url}#t={t}")
        console = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
        assert done.returncode == 0 and not console, console or done.stderr[-2000:]
        shots[t] = matplotlib.image.imread(tmp_path / (t + ".png"))[..., :3]
    rest, later = shots["0"], shots["2.5"]
    # drawn: the bark's dark brown, which nothing else on the page has, covers pixels
    bark = (rest[..., 0] > rest[..., 2] + 0.08) & (rest.sum(-1) < 1.2)
    assert bark.sum() > 300, bark.sum()
    assert (np.abs(rest - BACKGROUND).sum(-1) > 0.1).sum() > 1000
    # moving: at 2.5 s the stalks bend; rows between the header and the slider bar only
    changed = np.abs(rest - later).sum(-1)[80:-60] > 0.1
    assert changed.sum() > 1000, changed.sum()
