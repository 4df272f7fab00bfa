"""The patrol picture's key: the believed track is drawn dashed as the key says, and the keepout and speed zones get
legend entries (in the colour they have on the map) when masks are given, and none otherwise."""

from __future__ import annotations

import numpy as np
import pytest

from navigation.costmap_filters import zone_overlay
from navigation.maps import OccupancyMap
from navigation.render import (
    BELIEVED_COLOUR,
    DASH,
    GAP,
    ROBOT_COLOUR,
    LocalizationMarks,
    RunPicture,
    draw_dashed,
    first_passes,
    render_frames,
    render_still,
    zone_legend,
)

RES = 0.05


def free_room(width_m: float = 6.0, height_m: float = 4.0) -> OccupancyMap:
    data = np.zeros((round(height_m / RES), round(width_m / RES)), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return OccupancyMap(data, RES)


def coverage(img: np.ndarray, colour: tuple[int, int, int], row: int, columns: slice) -> float:
    """The share of the pixels of one row (and the rows next to it) drawn in ``colour`` (anti-aliasing allowed)."""
    band = (np.abs(img[row - 1:row + 2, columns].astype(int) - colour).sum(axis=-1) < 160).any(axis=0)
    return float(band.mean())


def test_a_dashed_line_has_gaps_however_finely_it_is_sampled():
    for step in (1, 3, 40):  # a track sampled every pixel, every few, or in long segments
        img = np.zeros((20, 420, 3), np.uint8)
        points = [(x, 10) for x in range(10, 411, step)]
        draw_dashed(img, points, (255, 255, 255), thickness=1)
        drawn = coverage(img, (255, 255, 255), 10, slice(10, 410))
        assert drawn == pytest.approx(DASH / (DASH + GAP), abs=0.08), step


def test_a_path_gone_back_and_forth_is_dashed_once():
    there = [(x, 10) for x in range(10, 300)]
    runs = first_passes(there + there[::-1] + there)
    assert sum(len(run) for run in runs) < len(there) + 20  # the way back and the second way there are left out
    img = np.zeros((20, 320, 3), np.uint8)
    for run in runs:
        draw_dashed(img, run, (255, 255, 255))
    assert coverage(img, (255, 255, 255), 10, slice(12, 298)) == pytest.approx(DASH / (DASH + GAP), abs=0.08)
    side_step = [(x, 10) for x in range(10, 150)] + [(150, y) for y in range(10, 40)]
    assert sum(len(r) for r in first_passes(there + side_step)) >= len(there) + 20  # new ground is drawn


def believed_along_a_line() -> LocalizationMarks:
    marks = LocalizationMarks()
    for k in range(400):  # one estimate every centimetre, as amcl's 10 Hz updates are on a slow robot
        x = 1.0 + 0.01 * k
        marks({"t": 0.1 * k, "type": "localization", "believed": {"x": x, "y": 2.0, "yaw": 0.0},
               "true": {"x": x, "y": 2.0, "yaw": 0.0}})
    return marks


def test_the_believed_track_is_purple_dashes():
    room = free_room()
    img = render_still(RunPicture(room, [(0.0, 1.0, 1.0, 0.0)], [], localization=believed_along_a_line()))
    rows = np.nonzero(np.all(img == BELIEVED_COLOUR, axis=-1).any(axis=1))[0]
    row = int(np.median(rows))
    columns = np.nonzero(np.all(img[row] == BELIEVED_COLOUR, axis=-1))[0]
    share = coverage(img, BELIEVED_COLOUR, row, slice(int(columns.min()), int(columns.max())))
    assert 0.4 < share < 0.8  # dashes and gaps, not a solid line (it was 1.0)


def zones(room: OccupancyMap, keepout: bool, speed: bool) -> np.ndarray | None:
    cells = np.zeros(room.data.shape, bool)
    cells[20:40, 20:60] = True
    limits = np.full(room.data.shape, np.inf)
    limits[50:70, 60:100] = 0.2
    return zone_overlay(cells if keepout else None, limits if speed else None, 0.5)


@pytest.mark.parametrize(("keepout", "speed"), [(True, True), (True, False), (False, True)])
def test_zones_have_legend_entries_only_when_given(keepout, speed):
    room = free_room()
    layer = zones(room, keepout, speed)
    legend = dict(zone_legend(layer))
    assert set(legend) == {name for name, given in (("keepout zone", keepout), ("speed zone", speed)) if given}
    picture = RunPicture(room, [(0.0, 1.0, 1.0, 0.0), (1.0, 1.2, 1.0, 0.0)], [], caption="c", zones=layer)
    for img in (render_still(picture), next(iter(render_frames(picture, max_side=400)))):
        for colour in legend.values():
            key = np.all(img[:90, :40] == colour, axis=-1).sum()  # the swatch beside the key's text, top left
            assert key >= 60, colour
    assert zone_legend(None) == []


def test_the_robots_orange_ring_has_a_key_entry_in_stills_and_frames():
    """The robot is drawn as an orange ring with a heading line; the key names it with a patch of that colour,
    in the still (where it ends) and in every frame (where it is now), and only when a robot is drawn."""
    room = free_room()
    picture = RunPicture(room, [(0.0, 1.0, 1.0, 0.0), (1.0, 3.0, 2.0, 0.5)], [], caption="c")
    for img in (render_still(picture), next(iter(render_frames(picture, max_side=400)))):
        swatch = np.all(img[:60, :40] == ROBOT_COLOUR, axis=-1).sum()  # the key's patch, top left, under "c"
        assert swatch >= 60
    nothing = render_still(RunPicture(room, [], [], caption="c"))
    assert np.all(nothing == ROBOT_COLOUR, axis=-1).sum() == 0  # no robot drawn, no key entry for it
