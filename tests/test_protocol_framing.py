"""Length-prefixed framing: any chunking of a stream gives back the same frames; caps hold."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from protocol.errors import FrameTooLarge, ProtocolError
from protocol.framing import MAX_FRAME_SIZE, FrameDecoder, encode_frame


def test_encode_frame_prefixes_the_big_endian_length() -> None:
    assert encode_frame("(syn)") == b"\x00\x00\x00\x05(syn)"
    assert encode_frame(b"") == b"\x00\x00\x00\x00"


def test_a_prefix_over_the_cap_raises_before_its_body_arrives() -> None:
    decoder = FrameDecoder(max_size=100)
    decoder.feed(encode_frame(b"x" * 100))  # exactly the cap is fine
    with pytest.raises(FrameTooLarge) as info:
        decoder.feed(struct.pack(">I", 101))  # only the prefix: no body has been sent yet
    assert info.value.position == 104  # the bad prefix follows the first 104-byte frame
    assert "100" in str(info.value) and "101" in str(info.value)
    assert decoder.buffered == 4  # nothing was reserved for the announced body
    with pytest.raises(FrameTooLarge):  # the stream stays refused
        decoder.feed(b"more")


def test_default_cap_is_one_mebibyte_and_a_4_gib_prefix_is_refused() -> None:
    decoder = FrameDecoder()
    assert decoder.max_size == MAX_FRAME_SIZE == 1 << 20
    with pytest.raises(ProtocolError):
        decoder.feed(b"\xff\xff\xff\xff")
    assert decoder.buffered == 4


payloads = st.lists(st.binary(max_size=300), max_size=12)


@given(payloads, st.lists(st.integers(min_value=0, max_value=4000), max_size=20))
def test_any_split_of_any_frame_sequence_decodes_to_the_same_messages(frames: list[bytes], cuts: list[int]) -> None:
    stream = b"".join(map(encode_frame, frames))
    points = sorted({0, len(stream), *(c % (len(stream) + 1) for c in cuts)})
    decoder = FrameDecoder()
    decoded: list[bytes] = []
    for start, end in zip(points, points[1:]):
        decoded.extend(decoder.feed(stream[start:end]))
    assert decoded == frames
    assert decoder.buffered == 0


@given(payloads, st.integers(min_value=1, max_value=3))
def test_a_partial_frame_stays_buffered_until_completed(frames: list[bytes], missing: int) -> None:
    stream = b"".join(map(encode_frame, frames)) + encode_frame(b"tail")
    decoder = FrameDecoder()
    assert decoder.feed(stream[:-missing]) == frames
    assert decoder.buffered == 8 - missing
    assert decoder.feed(stream[-missing:]) == [b"tail"]
