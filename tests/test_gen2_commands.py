"""Gen2 reader commands: bit-exact against published bitstreams (gen2-and-validation-anchors.md
§3.3, §4.4) and all 1000 Query + 1000 ACK bitstreams of the PASS selftest golden file."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.io import loadmat

from rfsim.core.errors import ConfigError
from rfsim.gen2.bits import bits_to_str, str_to_bits
from rfsim.gen2.commands import (
    ACK,
    NAK,
    CommandParseError,
    Query,
    QueryAdjust,
    QueryRep,
    Read,
    ReqRN,
    Select,
    command_name,
    command_preamble,
    ebv_decode,
    ebv_encode,
    encode,
    parse,
)

# (bits as published, expected command) — §3.3 (from a Verilog testbench with correct CRCs)
PUBLISHED = [
    ("1010 100 100 01 00011011 00001011 01110001110 1 1011101100000001",
     Select(target=4, action=4, membank=1, pointer=0b00011011, mask="01110001110", truncate=True)),
    ("1000 0 01 1 10 01 0 0011 01000",
     Query(dr="8", m=2, trext=True, sel="~sl", session=1, target="A", q=3)),
    ("1001 01 011", QueryAdjust(session=1, updn=-1)),
    ("00 01", QueryRep(session=1)),
    ("01 0000010111111100", ACK(rn16=0b0000010111111100)),
    ("11000001 0000010111111100 1111001111000010", ReqRN(rn16=0b0000010111111100)),
    ("11000010 00 00000000 00000010 0000101111111000 1010101110001111",
     Read(membank=0, word_ptr=0, word_count=2, rn16=0b0000101111111000)),
    ("11000001 0000101111111000 1001000001001001", ReqRN(rn16=0b0000101111111000)),
    # Query CRC-5 table, §3.3 (DR 8, FM0, TRext 0, All, S0, A)
    ("1000000000000000010000", Query(dr="8", m=1, q=0)),
    ("1000 0 00 0 00 00 0 0001 11001", Query(q=1)),
    ("1000 0 00 0 00 00 0 1111 11100", Query(q=15)),
    # §3.5 Query bitstreams (S0, A, All, TRext 0, Q 4) with real CRC-5
    ("1000000000000010011101", Query(dr="8", m=1, q=4)),
    ("1000100000000010000101", Query(dr="64/3", m=1, q=4)),
    ("1000110000000010001001", Query(dr="64/3", m=4, q=4)),
    # NAK, §4.4
    ("11000000", NAK()),
]


@pytest.mark.parametrize(("text", "cmd"), PUBLISHED, ids=[type(c).__name__ for _, c in PUBLISHED])
def test_published_bitstreams_encode_and_parse(text, cmd):
    expected = text.replace(" ", "")
    bits = encode(cmd)
    assert bits.dtype == np.uint8
    assert bits_to_str(bits) == expected
    assert parse(str_to_bits(expected)) == cmd


def test_published_lengths():
    lengths = {command_name(c): len(t.replace(" ", "")) for t, c in PUBLISHED}
    assert lengths == {"Select": 56, "Query": 22, "QueryAdjust": 9, "QueryRep": 4, "ACK": 18,
                       "Req_RN": 40, "Read": 58, "NAK": 8}


@pytest.mark.parametrize(
    ("value", "text"),
    [(0, "00000000"), (127, "01111111"), (128, "1000000100000000"), (16383, "1111111101111111"),
     (16384, "100000011000000000000000")],
)
def test_ebv(value, text):
    assert bits_to_str(ebv_encode(value)) == text
    assert ebv_decode(str_to_bits(text + "101"), 0) == (value, len(text))


def test_ebv_truncated_raises():
    with pytest.raises(ValueError):
        ebv_decode(str_to_bits("10000001"))


# ------------------------------------------------------------------ PASS golden file

# PASS conventions (pass-paris-simulator.md §2.1): dr stored as the number 8 or 64/3 (float),
# m as 1/2/4/8, trext 0/1, sel 'all'/'~sl'/'sl', session 's0'..'s3', target 'a'/'b', q 0..15;
# ack rn16 as a 4-digit hex string.
def _pass_query(s) -> Query:
    dr = float(s.dr)
    if dr == 8:
        dr_name = "8"
    elif abs(dr - 64 / 3) < 1e-9:
        dr_name = "64/3"
    else:
        raise AssertionError(f"unexpected PASS dr {s.dr!r}")
    return Query(dr=dr_name, m=int(s.m), trext=bool(s.trext), sel={"all": "all", "~sl": "~sl", "sl": "sl"}[s.sel],
                 session=int(str(s.session)[1]), target=str(s.target).upper(), q=int(s.q))


def test_pass_query_and_ack_bitstreams(reference_data):
    m = loadmat(reference_data / "pass-selftest" / "results_reader_command.mat",
                squeeze_me=True, struct_as_record=False)
    settings_, results = m["settings"], m["results"]
    queries, acks = np.atleast_1d(settings_.query), np.atleast_1d(settings_.ack)
    exp_q, exp_a = np.asarray(results.query), np.asarray(results.ack)
    assert len(queries) == 1000 and exp_q.shape == (1000, 22)
    assert len(acks) == 1000 and exp_a.shape == (1000, 18)
    n_q = n_a = 0
    for s, expected in zip(queries, exp_q):
        cmd = _pass_query(s)
        bits = encode(cmd)
        np.testing.assert_array_equal(bits, expected.astype(np.uint8))
        assert parse(expected) == cmd
        n_q += 1
    for s, expected in zip(acks, exp_a):
        cmd = ACK(rn16=int(str(s.rn16), 16))
        np.testing.assert_array_equal(encode(cmd), expected.astype(np.uint8))
        assert parse(expected) == cmd
        n_a += 1
    assert (n_q, n_a) == (1000, 1000)
    # the file covers every field value (otherwise the test would prove little)
    parsed = [parse(e) for e in exp_q]
    assert {p.dr for p in parsed} == {"8", "64/3"}
    assert {p.m for p in parsed} == {1, 2, 4, 8}
    assert {p.sel for p in parsed} == {"all", "~sl", "sl"}
    assert {p.session for p in parsed} == {0, 1, 2, 3}
    assert {p.q for p in parsed} == set(range(16))


# ------------------------------------------------------------------ parse errors


def test_parse_bad_crc():
    for text in ("1000000000000010011101", "11000001 0000010111111100 1111001111000010",
                 "11000010 00 00000000 00000010 0000101111111000 1010101110001111",
                 "1010 100 100 01 00011011 00001011 01110001110 1 1011101100000001"):
        bits = str_to_bits(text)
        bits[-3] ^= 1
        with pytest.raises(CommandParseError, match="CRC"):
            parse(bits)


@pytest.mark.parametrize("text", ["11001111 11000000001100000000 0000101111111000 0100001111010101",
                                  "1011 0000", "11111111", "1110 0000 0000"])
def test_parse_unknown_prefix(text):
    with pytest.raises(CommandParseError, match="prefix"):
        parse(str_to_bits(text))


@pytest.mark.parametrize("text", ["000", "00010", "01 000001011111110", "1000000000000010011101 0",
                                  "1001 01 0110", "110000000", "11000001 0000010111111100 111100111100001",
                                  "0", ""])
def test_parse_wrong_length(text):
    with pytest.raises(CommandParseError):
        parse(str_to_bits(text))


def test_parse_invalid_updn():
    with pytest.raises(CommandParseError, match="UpDn"):
        parse(str_to_bits("1001 00 001"))


def test_parse_error_is_value_error():
    assert issubclass(CommandParseError, ValueError)


# ------------------------------------------------------------------ validation


@pytest.mark.parametrize(
    ("factory", "key"),
    [
        (lambda: Query(dr=21.333), "query.dr"),
        (lambda: Query(m=3), "query.m"),
        (lambda: Query(sel="none"), "query.sel"),
        (lambda: Query(session=4), "query.session"),
        (lambda: Query(target="C"), "query.target"),
        (lambda: Query(q=16), "query.q"),
        (lambda: Query(q=-1), "query.q"),
        (lambda: QueryAdjust(updn=2), "queryadjust.updn"),
        (lambda: QueryRep(session=5), "queryrep.session"),
        (lambda: ACK(rn16=0x10000), "ack.rn16"),
        (lambda: ReqRN(rn16=-1), "req_rn.rn16"),
        (lambda: Read(word_count=256), "read.word_count"),
        (lambda: Select(mask="012"), "select.mask"),
        (lambda: Select(target=5), "select.target"),
    ],
)
def test_field_validation(factory, key):
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")) as err:
        factory()
    assert isinstance(err.value, ValueError)


def test_names_and_preambles():
    assert command_name(Query()) == "Query" and command_name(ReqRN) == "Req_RN"
    assert command_preamble(Query()) == "query"
    assert {command_preamble(c) for c in (QueryRep(), QueryAdjust(), ACK(), NAK(), ReqRN(), Read(), Select())} == {
        "frame-sync"}
    with pytest.raises(TypeError):
        encode("Query")


# ------------------------------------------------------------------ round trip property

_sessions = st.integers(0, 3)
_rn = st.integers(0, 0xFFFF)
commands = st.one_of(
    st.builds(Query, dr=st.sampled_from(["8", "64/3"]), m=st.sampled_from([1, 2, 4, 8]), trext=st.booleans(),
              sel=st.sampled_from(["all", "all01", "~sl", "sl"]), session=_sessions,
              target=st.sampled_from(["A", "B"]), q=st.integers(0, 15)),
    st.builds(QueryRep, session=_sessions),
    st.builds(QueryAdjust, session=_sessions, updn=st.sampled_from([-1, 0, 1])),
    st.builds(ACK, rn16=_rn),
    st.just(NAK()),
    st.builds(ReqRN, rn16=_rn),
    st.builds(Read, membank=st.integers(0, 3), word_ptr=st.integers(0, 2**32 - 1), word_count=st.integers(0, 255),
              rn16=_rn),
    st.builds(Select, target=st.integers(0, 4), action=st.integers(0, 7), membank=st.integers(0, 3),
              pointer=st.integers(0, 2**32 - 1), mask=st.text(alphabet="01", max_size=255), truncate=st.booleans()),
)


@settings(max_examples=300, deadline=None)
@given(commands)
def test_encode_parse_round_trip(cmd):
    bits = encode(cmd)
    assert parse(bits) == cmd
    # any single bit flip must never parse back to the same command
    flipped = bits.copy()
    flipped[-1] ^= 1
    try:
        assert parse(flipped) != cmd
    except CommandParseError:
        pass
