"""docs/api.md runs: every ```python block, in order, in one namespace, from the repository root."""

from __future__ import annotations

import re

from golden_util import ROOT


def test_the_api_page_runs(monkeypatch):
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 3
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, "docs/api.md", "exec"), namespace)
