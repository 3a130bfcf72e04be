"""The plan's relay figure: its node labels."""

from __future__ import annotations

import numpy as np

from swarm.report.plan_figures import _node_labels, node_names


def test_relays_standing_side_by_side_share_one_label() -> None:
    """A redundancy-2 relay puts its two chains' robots a metre or two apart (relay.yaml: R5 and
    R7 3 m apart on a 370 m graph), and their labels printed over each other: one label names
    both, at the first; nodes farther apart keep their own."""
    fixed = [[240.0, 12.0], [30.0, 225.0], [390.0, 235.0]]
    nodes = np.array([*fixed, [170.0, 83.0], [172.0, 85.5], [290.0, 86.0]])
    names = node_names(2, 3)
    labels = _node_labels(nodes, names)
    assert [name for _, name in labels] == ["source", "sink 1", "sink 2", "R1, R2", "R3"]
    np.testing.assert_array_equal(labels[3][0], nodes[3])
    # every name is printed exactly once
    assert sorted(", ".join(name for _, name in labels).split(", ")) == sorted(names)
    # a lone node, and nodes all far apart, label as they are
    ((at, name),) = _node_labels(nodes[:1], names[:1])
    assert name == "source" and np.array_equal(at, nodes[0])
    assert [name for _, name in _node_labels(nodes[:3], names[:3])] == names[:3]
