"""Images from ROS bags and MCAP files (plug-in ``2d.bag``): ``sensor_msgs/Image`` and ``CompressedImage``.

``bag:PATH[,topic=NAME,start=S,end=S,rate=R]``, or the plain path of a ``.bag``/``.mcap`` file or a ROS 2 bag
folder. Without ``topic`` the recording's only image topic is read; depth images (16UC1, 32FC1) do not count,
they are 3D data. Frames are BGR (colour, alpha dropped) or single-channel uint8 (mono8; mono16 scaled to 8
bits), with the message's header stamp and frame_id. Compressed images (jpeg, png) are decoded with OpenCV
here, which is why this lives in objrec2d and not in objrec_ros. The registry knows this source's forms from
:mod:`objrec2d.bag_declaration` and imports this module (and objrec_ros) only when a spec names a bag.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

import cv2
import numpy as np

from objrec_core import SourceSpec
from objrec_ros.bags import TopicInfo, header_frame_id, header_stamp_ns
from objrec_ros.decode import COMPRESSED_IMAGE, IMAGE, DecodeError, encoding_of, image_to_bgr, is_depth_encoding
from objrec_ros.source import BagSource, Decoded
from strictio import InputError

from .bag_declaration import IMAGE_BAG
from .sources import decode_image


def decode_compressed(message: Any) -> np.ndarray:
    """A ``sensor_msgs/CompressedImage`` (jpeg or png) as a 2D frame: BGR, or single-channel for mono."""
    fmt = str(message.format).strip().lower()
    if "compresseddepth" in fmt:
        raise DecodeError(f"format {message.format!r}: compressed depth is not a picture (jpeg and png are read)")
    data = message.data
    buffer = np.ascontiguousarray(data, dtype=np.uint8).reshape(-1).tobytes() if isinstance(data, np.ndarray) \
        else bytes(data)
    if not buffer.startswith((b"\xff\xd8", b"\x89PNG\r\n\x1a\n")):
        raise DecodeError(f"compressed image (format {message.format!r}) cannot be decoded: corrupt, or not "
                          "jpeg or png")
    try:  # its size is checked from the header first: a few bytes may claim gigapixels
        image = decode_image(buffer, "compressed image", cv2.IMREAD_UNCHANGED)
    except InputError as exc:
        raise DecodeError(f"compressed image (format {message.format!r}): {exc.message}") from None
    if image.dtype == np.uint16:
        image = (image >> 8).astype(np.uint8)
    elif image.dtype != np.uint8:
        raise DecodeError(f"compressed image of {image.dtype} pixels; 8 or 16 bits expected")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    elif image.ndim == 3 and image.shape[2] == 4:
        image = image[..., :3]
    if image.ndim == 3 and re.search(r"compressed\s+rgb", fmt):
        image = image[..., ::-1]  # the encoder was handed RGB as if it were BGR: its file holds them swapped
    return np.ascontiguousarray(image)


def decode_picture(msgtype: str, message: Any) -> np.ndarray:
    """An Image or CompressedImage message as a 2D frame."""
    return decode_compressed(message) if msgtype == COMPRESSED_IMAGE else image_to_bgr(message)


class ImageBagSource(BagSource):
    """The images of one topic of a ROS 1 bag, a ROS 2 bag (sqlite3 or MCAP) or an MCAP file."""

    kind = "2d"
    summary = IMAGE_BAG.summary
    noun = "image"
    readable_types = "sensor_msgs/Image or sensor_msgs/CompressedImage"

    @classmethod
    def from_spec(cls, spec: SourceSpec, options: dict[str, Any]) -> ImageBagSource:
        return cls(cls.recording_path(spec, options), topic=options["topic"], start=options["start"],
                   end=options["end"], rate=options["rate"], name=spec.text)

    def _is_depth(self, info: TopicInfo) -> bool:
        """Whether an image topic holds depth (by its first message), so that it is not offered as pictures."""
        try:
            found = self.recording.first(info.name)
        except Exception:  # an unreadable topic is reported if chosen, not while looking
            return False
        if found is None:
            return False
        message = found[1]
        if info.msgtype == IMAGE:
            return is_depth_encoding(encoding_of(message))
        return "compresseddepth" in str(getattr(message, "format", "")).lower()

    def _candidates(self) -> list[TopicInfo]:
        images = [t for t in self.recording.topics() if t.msgtype in (IMAGE, COMPRESSED_IMAGE)]
        return [t for t in images if not self._is_depth(t)]

    def _select(self, topic: str) -> TopicInfo:
        info = self.choose(topic, self._candidates)
        if info.msgtype not in (IMAGE, COMPRESSED_IMAGE):
            raise self.wrong_type(info, self._candidates())
        _, message = self.first_message(info.name)
        self.check(info.name, 0, decode_picture, info.msgtype, message)
        return info

    def _decoded(self) -> Iterator[Decoded]:
        msgtype = self.topic_info.msgtype
        for log_time, message in self.recording.messages(self.topic_info.name, self.start, self.end):
            image = decode_picture(msgtype, message)
            yield log_time, header_stamp_ns(message, 0), header_frame_id(message), image
