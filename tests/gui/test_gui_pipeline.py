"""The Pipeline menu: modules from the registry are added, removed and reordered in the running window,
and the saved parameter file holds the new pipeline (which objrec-detect can build)."""

from __future__ import annotations

import yaml
from PySide6.QtGui import QAction
from PySide6.QtWidgets import QFileDialog

from objrec_apps.define import starting_system
from objrec_core import build_system
from tests.qt_waits import HANG_GUARD_MS


def menu_action(menu, name: str) -> QAction:
    menu.populate()
    action = menu.findChild(QAction, name)
    assert action is not None, f"no action {name} in the Pipeline menu"
    assert action.isEnabled() and action.parent() is not None
    return action


def test_the_pipeline_menu_adds_a_module_and_the_saved_file_holds_it(make_gui, monkeypatch, tmp_path, qtbot):
    gui = make_gui(starting_system("hsv"))
    menu = gui.pipeline_menu
    menu_action(menu, "add:MorphologyFilter").trigger()
    assert [m.id for m in gui.system.modules] == ["colour", "open", "MorphologyFilter", "blobs"]
    assert gui.statusBar().currentMessage() == "added MorphologyFilter"
    qtbot.waitUntil(lambda: [p.module.id for p in gui.panels.panels] == ["colour", "open", "MorphologyFilter",
                                                                         "blobs"])
    gui.panels.panel("MorphologyFilter").editors["operation"].combo.setCurrentText("close")
    qtbot.waitUntil(lambda: "MorphologyFilter" in gui.stage_views.views, timeout=HANG_GUARD_MS)

    path = tmp_path / "with_close.yaml"
    monkeypatch.setattr(QFileDialog, "getSaveFileName", staticmethod(lambda *a: (str(path), "")))
    gui.save_as_action.trigger()
    pipeline = yaml.safe_load(path.read_text())["pipeline"]
    assert [(e["type"], e["id"]) for e in pipeline] == [
        ("HSVFilter", "colour"), ("MorphologyFilter", "open"), ("MorphologyFilter", "MorphologyFilter"),
        ("BinaryDetector", "blobs"),
    ]
    assert pipeline[2]["parameters"]["operation"] == "close"
    rebuilt = build_system(path)  # what objrec-detect does with it
    assert [m.id for m in rebuilt.modules] == ["colour", "open", "MorphologyFilter", "blobs"]


def test_a_second_module_of_a_type_gets_its_own_id_and_detectors_go_last(make_gui):
    gui = make_gui(starting_system("hsv"))
    menu = gui.pipeline_menu
    menu_action(menu, "add:HSVFilter").trigger()
    menu_action(menu, "add:BinaryDetector").trigger()
    assert [m.id for m in gui.system.modules] == ["colour", "open", "HSVFilter", "blobs", "BinaryDetector"]


def test_remove_and_reorder(make_gui, qtbot):
    gui = make_gui(starting_system("hsv"))
    menu = gui.pipeline_menu
    menu_action(menu, "down:colour").trigger()
    assert [m.id for m in gui.system.modules] == ["open", "colour", "blobs"]
    menu_action(menu, "up:colour").trigger()
    menu_action(menu, "remove:open").trigger()
    assert [m.id for m in gui.system.modules] == ["colour", "blobs"]
    assert gui.statusBar().currentMessage() == "removed MorphologyFilter 'open'"
    qtbot.waitUntil(lambda: [p.module.id for p in gui.panels.panels] == ["colour", "blobs"])
    qtbot.waitUntil(lambda: list(gui.stage_views.views) == ["input", "colour", "blobs"], timeout=HANG_GUARD_MS)


def test_3d_modules_cannot_join_a_2d_pipeline(make_gui):
    gui = make_gui(starting_system("hsv"))
    menu = gui.pipeline_menu
    menu.populate()
    kinds = {a.text(): a.menu().isEnabled() for a in menu.actions() if a.menu() is not None}
    assert kinds["Add 2d module (images)"] is True
    if "Add 3d module (point clouds)" in kinds:
        assert kinds["Add 3d module (point clouds)"] is False
    types = menu.module_types()
    three_d = [name for name, klass in types.items() if klass.kind == "3d"]
    if three_d:
        assert menu.add_module(three_d[0]) is None
        assert gui.statusBar().currentMessage().startswith(f"cannot add {three_d[0]}:")
        assert [m.id for m in gui.system.modules] == ["colour", "open", "blobs"]


def test_an_empty_window_builds_a_pipeline_from_the_menu(make_gui, qtbot):
    gui = make_gui(None, wait=False)
    assert gui.system.modules == () and gui.panels.empty_label.isVisibleTo(gui.panels)
    assert gui.worker.source is None  # demo is a source of 2d and of 3d data: it waits for the pipeline's kind
    assert "(waiting for a pipeline)" in gui.source_bar.name_label.text()
    menu = gui.pipeline_menu
    for name in ("add:HSVFilter", "add:BinaryDetector"):
        menu_action(menu, name).trigger()
    assert gui.system.kind == "2d"
    with qtbot.waitSignal(gui.frameShown, timeout=HANG_GUARD_MS):
        pass
    qtbot.waitUntil(lambda: list(gui.stage_views.views) == ["input", "HSVFilter", "BinaryDetector"],
                    timeout=HANG_GUARD_MS)
    assert gui.worker.source_kind == "2d" and gui.source_bar.name_label.text().strip() == "demo"


def test_a_pipeline_that_becomes_3d_gets_the_3d_demo_and_view(make_gui, qtbot, tmp_path):
    import cv2

    from objrec2d import DemoScene

    image = tmp_path / "frame.png"
    cv2.imwrite(str(image), DemoScene().render(0)[0])
    gui = make_gui(None, source=str(image), wait=False, paused=True)  # only a 2d source reads a .png
    qtbot.waitUntil(lambda: gui.worker.source is not None, timeout=HANG_GUARD_MS)
    assert type(gui.worker.source).__module__.startswith("objrec2d") and gui.worker.source_kind == "2d"
    menu = gui.pipeline_menu
    three_d = [name for name, klass in menu.module_types().items() if klass.kind == "3d"]
    if not three_d:
        return  # the 3D extra is not installed
    menu_action(menu, "add:DistanceFilter").trigger()
    assert gui.system.kind == "3d" and gui.central.currentWidget() is gui.view3d
    qtbot.waitUntil(lambda: type(gui.worker.source).__module__.startswith("objrec3d"), timeout=HANG_GUARD_MS)
    qtbot.waitUntil(lambda: gui.source_bar.name_label.text().strip() == "demo", timeout=HANG_GUARD_MS)
    assert gui.worker.source_kind == "3d"
