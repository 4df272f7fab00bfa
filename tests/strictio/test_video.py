"""strictio.video: the one verified video writer (navigation's animations, objrec-detect's annotations)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from strictio import OutputError
from strictio.video import VideoFile, readable_frames


@pytest.mark.parametrize("suffix", [".avi", ".mp4"])
def test_every_frame_written_reads_back(tmp_path, suffix):
    video = VideoFile(tmp_path / f"v{suffix}", 10.0, (64, 48))
    for k in range(12):
        video.write(np.full((48, 64, 3), k * 20, np.uint8))
    video.close()
    assert video.frames == 12 and readable_frames(tmp_path / f"v{suffix}", 12) == 12
    assert readable_frames(tmp_path / f"v{suffix}", 5) == 5  # never counts past what is expected


def test_a_video_short_of_frames_is_an_error_naming_the_shown_path(tmp_path):
    temporary = tmp_path / ".tmp-run.avi"
    video = VideoFile(temporary, 10.0, (64, 48), shown_as=tmp_path / "run.avi", watch_growth=False)
    for k in range(5):
        video.write(np.full((48, 64, 3), k, np.uint8))
    video.frames = 9  # as if four frames had gone nowhere
    with pytest.raises(OutputError, match=r"run\.avi: cannot be written completely \(a full disk or a file size "
                                          r"limit\?\): 5 of 9 frames are readable$"):
        video.close()


def test_a_missing_file_has_no_readable_frame(tmp_path):
    assert readable_frames(tmp_path / "none.avi", 3) == 0


def test_importing_it_loads_no_opencv():
    code = "import sys, strictio.video; print('cv2' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False)
    assert result.stdout.strip() == "False", result.stderr
