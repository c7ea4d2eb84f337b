"""Which of a raw CAN log's frames a decode keeps, a part at a time
(rwhonet.data.keptframes): the bound on the frames kept, which stands for a raw CAN log's
memory where ``data.max_file_mb`` counts another drive's file size."""

from __future__ import annotations

import numpy as np
import pytest

from rwhonet.data.keptframes import KEPT_FRAME_BYTES, FrameFilter, Kept, TooManyFrames

KEEP = FrameFilter(frozenset({(0x1A0, False), (0x18FEF100, True)}))


def _part(ids, extended=None):  # type: ignore[no-untyped-def]
    ids = np.asarray(ids, np.int64)
    ext = np.zeros(ids.size, bool) if extended is None else np.asarray(extended)
    return ids, ext, np.zeros(ids.size, np.int64)


def test_the_bound_is_the_memory_at_the_bytes_a_kept_frame_costs():
    assert FrameFilter.frames_for(512) == 512 * 2**20 // KEPT_FRAME_BYTES == 2_097_152
    assert FrameFilter.frames_for(0.001) == 4


@pytest.mark.parametrize("limit", [0, 1, 3, 4, 5])
def test_kept_frames_past_the_bound_are_refused_at_the_frame_that_passes_it(limit):
    """Parts of 4, 5 and 3 messages, the kept frames the log's 2nd, 4th, 6th, 9th (an
    extended identifier) and 12th (a remote frame, the 7th, kept as every message that is
    no data frame is, not counted): the bound of ``limit`` frames passed at the kept frame
    after the ``limit``-th, in whichever part."""
    kept_at = [2, 4, 6, 9, 12]
    keep = FrameFilter(KEEP.messages, max_frames=limit)
    counted = Kept(keep)
    parts = [
        (_part([0x100, 0x1A0, 0x101, 0x1A0]), None),
        (_part([0x102, 0x1A0, 0x1A0, 0x103, 0x18FEF100], [0, 0, 0, 0, 1]), [0, 0, 1, 0, 0]),
        (_part([0x104, 0x105, 0x1A0]), None),
    ]
    if limit >= len(kept_at):
        for part, remote in parts:
            counted.part(*part, None if remote is None else np.array(remote, bool))
        assert counted.kept == len(kept_at) and counted.dropped == 6
        return
    with pytest.raises(TooManyFrames) as err:
        for part, remote in parts:
            counted.part(*part, None if remote is None else np.array(remote, bool))
    assert (err.value.max_frames, err.value.row) == (limit, kept_at[limit])


def test_a_reader_s_own_rows_name_the_frame_past_the_bound():
    """A candump or TRC log numbers its frames by their lines, which a reader gives."""
    counted = Kept(FrameFilter(KEEP.messages, max_frames=1))
    counted.part(*_part([0x1A0, 0x100]), rows=np.array([3, 4]))
    with pytest.raises(TooManyFrames) as err:
        counted.part(*_part([0x100, 0x1A0]), rows=np.array([7, 9]))
    assert err.value.row == 9


def test_no_bound_keeps_every_frame_of_the_messages():
    counted = Kept(KEEP)
    at = counted.part(*_part([0x1A0] * 1000 + [0x100]))
    assert at.size == counted.kept == 1000 and KEEP.bound(0, np.ones(10**6, bool)) == 10**6
