"""strictio: how the project reads and writes files it does not trust.

One opener (:func:`open_input`) refuses what is not a regular file and caps the bytes read; one YAML reader
(:func:`read_yaml`) refuses tags, aliases, duplicate keys and deep nesting; one writer
(:func:`write_atomically`) replaces a file whole or not at all; :mod:`strictio.limits` declares how much any
input may claim. What crosses the process's boundary besides files has its one home here too:
:mod:`strictio.shown` shows untrusted text (escaped, cut short), :mod:`strictio.video` writes a video and
checks it can be read back, :mod:`strictio.signals` turns Ctrl-C and SIGTERM into a clean stop. It imports
nothing of the project, so the framework and the navigation stack share it without depending on each other.
"""

from .atomic import write_atomically
from .errors import InputError, OutputError
from .limits import ALL_LIMITS, CLOUD_POINTS, IMAGE_PIXELS, MAP_CELLS, POSES, YAML_NODES, Limit, LimitError
from .opener import DEFAULT_LIMIT, open_input, read_bytes, read_text
from .yaml_reader import YAMLLimits, read_yaml, yaml_text

__all__ = [
    "ALL_LIMITS",
    "CLOUD_POINTS",
    "DEFAULT_LIMIT",
    "IMAGE_PIXELS",
    "MAP_CELLS",
    "POSES",
    "YAML_NODES",
    "InputError",
    "Limit",
    "LimitError",
    "OutputError",
    "YAMLLimits",
    "open_input",
    "read_bytes",
    "read_text",
    "read_yaml",
    "write_atomically",
    "yaml_text",
]
