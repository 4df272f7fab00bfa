"""Rows of a Rerun recording, per entity, for tests that check what a command logged (rerun's own reader)."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
from rerun.chunk import RrdReader


def _cell(value: pa.Scalar) -> object:
    """One cell as Python, with big numeric batches (pixels, points) as NumPy arrays."""
    if not value.is_valid:
        return None
    item = value.type.value_type if pa.types.is_list(value.type) else None
    if item is not None and pa.types.is_fixed_size_list(item):
        return value.values.flatten().to_numpy(zero_copy_only=False).reshape(-1, item.list_size)
    if item is not None and pa.types.is_list(item) and pa.types.is_integer(item.value_type):
        return [blob.values.to_numpy(zero_copy_only=False) for blob in value.values]
    return value.as_py()


def read_recording(path: Path) -> dict[str, list[dict[str, object]]]:
    """Every entity's rows as dicts of column -> value (timelines as integers: ns), in log order."""
    rows: dict[str, list[dict[str, object]]] = {}
    for chunk in RrdReader(path).stream():
        batch = chunk.to_record_batch()
        columns = {}
        for name in batch.schema.names[1:]:
            column = batch.column(name)
            if pa.types.is_timestamp(column.type) or pa.types.is_duration(column.type):
                column = column.cast(pa.int64())
            columns[name] = column
        rows.setdefault(chunk.entity_path, []).extend(
            {name: _cell(column[i]) for name, column in columns.items()} for i in range(batch.num_rows))
    return rows
