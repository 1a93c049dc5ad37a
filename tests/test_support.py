"""The suite on pytest-xdist workers (``make test``): the ports tests/support.py hands out are
free, and unique across the workers of a run."""

from __future__ import annotations

import socket

import pytest

from tests.support import PORTS, PortDrawer, free_tcp_port, free_udp_port, port_slice


def test_the_workers_of_a_run_get_disjoint_slices_below_the_ephemeral_range() -> None:
    slices = [port_slice(f"gw{i}", "3") for i in range(3)]
    assert all(len(s) == len(PORTS) // 3 for s in slices)
    assert not set(slices[0]) & set(slices[1]) and not set(slices[1]) & set(slices[2])
    assert all(s.start >= PORTS.start and s.stop <= PORTS.stop for s in slices)
    assert PORTS.stop <= 32768  # Linux's ephemeral ports start at 32768
    assert port_slice("master", "1") == PORTS  # no xdist: all of it


def test_a_drawer_never_repeats_a_port_before_going_round_its_slice() -> None:
    drawer = PortDrawer(port_slice("gw1", "2"))
    drawn = [drawer.draw(socket.SOCK_STREAM) for _ in range(200)]
    assert len(set(drawn)) == len(drawn)
    assert all(p in port_slice("gw1", "2") for p in drawn)


def test_a_port_in_use_is_skipped() -> None:
    with socket.socket() as taken:
        port = free_tcp_port()
        taken.bind(("127.0.0.1", port))
        drawer = PortDrawer(range(port, port + 2))
        assert drawer.draw(socket.SOCK_STREAM) == port + 1
        assert drawer.draw(socket.SOCK_STREAM) == port + 1  # round again: still taken
        with pytest.raises(RuntimeError, match="no free port"):
            PortDrawer(range(port, port + 1)).draw(socket.SOCK_STREAM)


def test_the_ports_handed_out_are_in_this_worker_s_slice_and_bindable() -> None:
    for port, kind in ((free_tcp_port(), socket.SOCK_STREAM),
                       (free_udp_port(), socket.SOCK_DGRAM)):
        assert port in port_slice()
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind(("127.0.0.1", port))
