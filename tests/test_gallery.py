"""The gallery renders in parallel, resumes without redoing work, and survives a failing entry."""
from __future__ import annotations

import json

from procgen.gallery import build_gallery, load_gallery


def _gallery(tmp_path, entries: str):
    g = tmp_path / "gallery.toml"
    g.write_text(entries)
    return g


def test_gallery_renders_resumes_and_reports_failures(host, tmp_path, monkeypatch):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[steps]]\nrule = "grid.noise"\nparams = { nx = 8, ny = 8 }\n'
                   '[[outputs]]\ndomain = "terrain"\nformat = "image_png"\noptions = { field = "surface__height" }\n')
    g = _gallery(tmp_path, f"""
[[entry]]
recipe = "demo/basics"
seeds = [1, 2]
title = "basics"
quick = {{ "steps.4.params.nx" = 32, "steps.4.params.ny" = 32 }}

[[entry]]
recipe = "{bad}"
id = "broken"
title = "fails on purpose"
set = {{ "steps.0.params.nx" = 8, "outputs.0.options.cmap" = "no_such_cmap" }}
""")
    monkeypatch.setattr(type(host), "gallery_lists", lambda self: [g])   # only this test's list
    assert [e.slug for e in load_gallery(host)] == ["demo-basics", "broken"]
    out = tmp_path / "out"
    rep = build_gallery(host, jobs=2, quick=True, out_dir=out, progress=False)
    assert [r.status for r in rep.results] == ["done", "done", "failed"]
    assert "no_such_cmap" in rep.failed[0].error and rep.failed[0].key == "broken"
    stamp = json.loads((out / "demo-basics/seed-1/.procgen-done.json").read_text())
    assert "outline.svg" in stamp["files"]
    index = (out / "index.html").read_text()
    assert "demo-basics/seed-2/outline.svg" in index and "failed" in index
    first = (out / "demo-basics/seed-1/outline.svg").stat().st_mtime_ns
    # a re-run does nothing for finished entries
    rep2 = build_gallery(host, jobs=1, quick=True, out_dir=out, progress=False)
    assert [r.status for r in rep2.results] == ["skipped", "skipped", "failed"]
    assert (out / "demo-basics/seed-1/outline.svg").stat().st_mtime_ns == first
    # an interrupted entry (half-written temp folder, no stamp) is redone; others are kept
    (out / "demo-basics/seed-2/.procgen-done.json").unlink()
    (out / "demo-basics/.tmp-seed-2-999").mkdir()
    rep3 = build_gallery(host, jobs=1, quick=True, out_dir=out, progress=False, only=["demo/*"])
    assert [r.status for r in rep3.results] == ["skipped", "done"]
    # a different quick setting is a different provenance: re-rendered
    rep4 = build_gallery(host, jobs=1, quick=False, out_dir=out, progress=False, only=["demo/*"])
    assert [r.status for r in rep4.results] == ["done", "done"]


def test_front_page_thumbnails_are_small_lazy_and_never_blank(tmp_path):
    import re

    import numpy as np
    from PIL import Image

    from procgen.site.pictures import THUMB_WIDTH, thumbs_html

    base = tmp_path / "e" / "seed-1"
    (base / "frames" / "step1").mkdir(parents=True)
    rng = np.random.default_rng(1)
    Image.fromarray(rng.integers(0, 255, (1000, 2000, 3), dtype=np.uint8)).save(base / "big.png")
    Image.fromarray(np.full((500, 500), 200, np.uint8)).save(base / "blank.png")     # a map that says nothing
    Image.fromarray((rng.random((300, 300)) * 65535).astype(np.uint16)).save(base / "height.png")
    Image.fromarray(rng.integers(0, 255, (400, 400), dtype=np.uint8)).save(base / "frames/step1/frame_0010.png")
    page = thumbs_html(tmp_path, "e/seed-1", ["blank.png", "big.png", "height.png"])
    srcs = re.findall(r'<img src="([^"]+)" width="(\d+)" height="(\d+)" loading="lazy"', page)
    assert [s for s, _, _ in srcs] == [f"_thumbs/e/seed-1/{THUMB_WIDTH}-big.webp",
                                       f"_thumbs/e/seed-1/{THUMB_WIDTH}-height.webp"]
    assert all(int(w) <= THUMB_WIDTH for _, w, _ in srcs)
    assert sum((tmp_path / s).stat().st_size for s, _, _ in srcs) < (base / "big.png").stat().st_size / 5
    # an entry whose only pictures are frames shows its last frame
    only_frames = thumbs_html(tmp_path, "e/seed-1", ["frames/step1/frame_0010.png"])
    assert "frames_step1_frame_0010.webp" in only_frames


def test_thesis_scale_entries_check_at_the_thesis_size(host):
    """``procgen gallery --scale thesis`` runs only entries with a thesis_scale table, each of
    whose overrides lands in a step that passes ``procgen check`` (memory estimate included)."""
    from procgen.gallery import overrides_for
    from procgen.recipes import load_recipe

    scaled = [e for e in load_gallery(host) if e.thesis_scale]
    assert {"meshes-plate-5-8", "meshes-plate-5-17", "cellnet-fig-1"} <= {e.slug for e in scaled}
    for e in scaled:
        recipe = load_recipe(e.recipe, host, overrides_for(e, False, thesis_scale=True))
        by_id = {s.id: s for s in recipe.steps}
        for key, value in e.thesis_scale.items():
            _, step, _, name = key.split(".")
            assert by_id[step].params[name] == value, (e.slug, key)
        assert overrides_for(e, True, thesis_scale=True) == overrides_for(e, True)   # quick wins
