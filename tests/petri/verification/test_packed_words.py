"""Markings packed into one word (issue 27): fields from the initial marking, places that never
change left out, repacking into wider fields, and the firing rule on whole arrays of words
against the token-count rule."""

from __future__ import annotations

import numpy as np

from petri.net import Net
from petri.verification import packed_words as pw
from petri.verification import reachability as rg


def test_fields_follow_the_initial_marking_and_unchanged_places_take_no_bits() -> None:
    net = Net("fields")
    a, b, c, d = (net.add_place(n) for n in "abcd")
    net.add_transition("t", {a: 1, c: 1}, {b: 1, c: 1})  # c is read, never changed
    net.add_transition("u", {c: 2, d: 1}, {a: 1, c: 2})  # c never holds 2: never enabled
    net.initial = {a: 5, c: 1}
    compiled = rg.compile_net(net, 255)
    packing = pw.first_packing(compiled, top=8)
    # the bits of the largest initial count (5) for each place a transition changes
    assert packing.bits[:4] == (3, 3, 0, 3) and packing.shift[:4] == (0, 3, 6, 6)
    assert packing.width == 9  # the row's padding cells take no bits either
    word = packing.pack(compiled.row)
    assert word == 5
    cells = packing.unpack(np.array([word], dtype=np.uint64), np.uint8)
    assert cells[0, :4].tolist() == [5, 0, 1, 0]
    wider = pw.Packing((4, 8) + packing.bits[2:], packing.constant)
    again = packing.repack(np.array([word | 1 << 3], dtype=np.uint64), wider)
    assert wider.unpack(again, np.uint8)[0, :4].tolist() == [5, 1, 1, 0]
    rule = pw.rules(compiled, packing, 255, 8)
    assert rule.always.tolist() == [] and rule.in_t.tolist() == [0]  # u: never enabled
    # where those bits would not fit a word, each place starts with its own count's
    for p in range(50):
        net.add_transition(f"v{p}", {net.add_place(f"x{p}"): 1}, {a: 1})
    net.initial[a] = 200
    compiled = rg.compile_net(net, 255)
    packing = pw.first_packing(compiled, top=8)
    assert packing.bits[:4] == (8, 1, 0, 1) and packing.width == 8 + 2 + 50
    wider = pw.widened(packing, {1: 2, 3: 5}, top=8, hint=8)  # 8 + 8 bits: too wide
    assert wider.bits[:4] == (8, 2, 0, 3) and wider.width == 8 + 5 + 50
    assert pw.widened(packing, {1: 2}, top=8, hint=3).bits[:4] == (8, 3, 0, 1)


def test_the_firing_rule_on_words_is_the_rule_on_token_counts() -> None:
    rng = np.random.default_rng(2)
    net = Net("weights")
    places = [net.add_place(f"p{i}") for i in range(5)]
    for t in range(8):
        ins = {int(p): int(rng.integers(1, 4)) for p in rng.choice(5, 2, replace=False)}
        outs = {int(p): int(rng.integers(1, 4)) for p in rng.choice(5, 2, replace=False)}
        net.add_transition(f"t{t}", ins, outs)
    net.initial = {p: 7 for p in places}
    compiled = rg.compile_net(net, 255)
    packing = pw.Packing((5,) * 5 + (0,) * (len(compiled.row) - 5), tuple([7] * 5) + (0,) * 3)
    counts = rng.integers(0, 25, size=(300, 5))
    rows = np.zeros((300, len(compiled.row)), dtype=np.uint8)
    rows[:, :5] = counts
    words = np.sort(np.array([packing.pack(r) for r in rows], dtype=np.uint64))
    rows = packing.unpack(words, np.uint8)  # in the words' order
    rule = pw.rules(compiled, packing, 28, 5)  # fields of 5 bits: 31 tokens, limit 28
    visited = words[::3].copy()
    found = pw.expand_slice(words, np.arange(len(words)), rule, packing, visited, None)
    expected: dict[int, int] = {}
    over = -1
    for r, row in enumerate(rows):
        for t in range(len(net.transitions)):
            if any(row[p] < w for p, w in net.transitions[t].inputs):
                assert not found.fires[t, r]
                continue
            after = row.astype(np.int64)
            for p, d in net.effect(t).items():
                after[p] += d
            if after.max() > 28:  # over the token limit: not recorded
                assert not found.fires[t, r]
                over = r * len(net.transitions) + t if over < 0 else over
                continue
            assert found.fires[t, r]
            key = packing.pack(after)
            if key not in set(visited.tolist()):
                expected.setdefault(key, r * len(net.transitions) + t)
    assert found.over == over and not found.need
    assert found.keys.tolist() == sorted(expected)
    assert found.order.tolist() == [expected[k] for k in sorted(expected)]
