"""The paper's DDST (section 4.2, Figure 4) built literally, as pointer lists, against BoxIndex.

A small reference of the structure as the paper describes it: a doubly linked x list, under
each x node a doubly linked y list, under each (x, y) node a doubly linked z list of boxes,
each box a list of its cells; cells inserted one by one (walking the lists, creating nodes),
moved by removal (freeing emptied nodes) and re-insertion, and the 27-box neighbourhood found
by following prev / next pointers.  ``BoxIndex`` (sorted arrays) must hold the same lists in
the same order, give the same neighbourhoods and the same box contents after the same moves.
"""
from __future__ import annotations

from itertools import product

import numpy as np

from procgen_cellnet.boxes import BoxIndex, box_keys


class Node:
    """One node of a sorted doubly linked list; ``child`` is the next level's head (or cells)."""

    def __init__(self, key: int, prev: "Node | None", nxt: "Node | None") -> None:
        self.key, self.prev, self.next = key, prev, nxt
        self.child: "Node | list[int] | None" = None


class DDST:
    def __init__(self) -> None:
        self.head: Node | None = None

    @staticmethod
    def _find_or_insert(head: Node | None, key: int) -> tuple[Node, Node]:
        """(new head, node of key): walk the sorted list, splice a node in if absent."""
        prev, cur = None, head
        while cur is not None and cur.key < key:
            prev, cur = cur, cur.next
        if cur is not None and cur.key == key:
            return head, cur
        node = Node(key, prev, cur)
        if cur is not None:
            cur.prev = node
        if prev is None:
            return node, node
        prev.next = node
        return head, node

    @staticmethod
    def _unlink(head: Node, node: Node) -> Node | None:
        if node.prev is not None:
            node.prev.next = node.next
        if node.next is not None:
            node.next.prev = node.prev
        return node.next if node is head else head

    def insert(self, cell: int, key: tuple[int, int, int]) -> None:
        self.head, xn = self._find_or_insert(self.head, key[0])
        xn.child, yn = self._find_or_insert(xn.child, key[1])
        yn.child, zn = self._find_or_insert(yn.child, key[2])
        zn.child = (zn.child or []) + [cell]

    def remove(self, cell: int, key: tuple[int, int, int]) -> None:
        xn = self._walk(self.head, key[0])
        yn = self._walk(xn.child, key[1])
        zn = self._walk(yn.child, key[2])
        zn.child.remove(cell)
        if not zn.child:                                  # free the emptied box ...
            yn.child = self._unlink(yn.child, zn)
            if yn.child is None:                          # ... column ...
                xn.child = self._unlink(xn.child, yn)
                if xn.child is None:                      # ... and x node
                    self.head = self._unlink(self.head, xn)

    @staticmethod
    def _walk(head: Node | None, key: int) -> Node | None:
        while head is not None and head.key < key:
            head = head.next
        return head if head is not None and head.key == key else None

    @staticmethod
    def _around(node: Node | None, key: int) -> list[Node]:
        """The nodes of keys key-1, key, key+1 reached from ``node`` by prev / next."""
        if node is None:
            return []
        out = [node] if node.key == key else []
        for n in (node.prev, node.next) if node.key == key else ():
            if n is not None and abs(n.key - key) == 1:
                out.append(n)
        return out

    def neighbourhood(self, key: tuple[int, int, int]) -> set[tuple[int, int, int]]:
        """Keys of the existing boxes among the 27 around ``key`` (which must exist)."""
        found = set()
        xn = self._walk(self.head, key[0])
        for x in self._around(xn, key[0]):
            for dy in (-1, 0, 1):
                y = self._walk(x.child, key[1] + dy)
                for dz in (-1, 0, 1):
                    z = self._walk(y.child, key[2] + dz) if y is not None else None
                    if z is not None:
                        found.add((x.key, y.key, z.key))
        return found

    def lists(self) -> list[tuple[int, list[tuple[int, list[tuple[int, list[int]]]]]]]:
        """x -> y -> z -> sorted cells, read by following next pointers."""
        out = []
        x = self.head
        while x is not None:
            ys, y = [], x.child
            while y is not None:
                zs, z = [], y.child
                while z is not None:
                    zs.append((z.key, sorted(z.child)))
                    z = z.next
                ys.append((y.key, zs))
                y = y.next
            out.append((x.key, ys))
            x = x.next
        return out


def index_lists(idx: BoxIndex):
    out = []
    for x in idx.x_nodes:
        ys = []
        for y in np.unique(idx.keys[idx.keys[:, 0] == x, 1]):
            boxes = np.nonzero((idx.keys[:, 0] == x) & (idx.keys[:, 1] == y))[0]
            ys.append((int(y), [(int(idx.keys[b, 2]), sorted(idx.cells_of(b).tolist())) for b in boxes]))
        out.append((int(x), ys))
    return out


def test_sorted_arrays_hold_the_ddst_lists_neighbourhoods_and_moves():
    rng = np.random.default_rng(5)
    p = rng.normal(size=(400, 3)) * [6, 6, 3] + [-1e5, 3, 7]        # negative keys too
    size = 2.0
    keys = [tuple(k) for k in box_keys(p, size).tolist()]
    ddst = DDST()
    for c in rng.permutation(len(p)):                   # insertion order does not matter
        ddst.insert(int(c), keys[c])
    idx = BoxIndex.build(p, size)
    for step in range(4):
        assert ddst.lists() == index_lists(idx)
        for b in range(idx.n_boxes):
            want = ddst.neighbourhood(tuple(idx.keys[b].tolist()))
            got = {tuple(k) for k in idx.keys[idx.neighbour_boxes(b)].tolist()}
            assert got == want
        # every 27-box stencil position answers alike, present or absent
        probe = idx.keys[rng.integers(0, idx.n_boxes, 50)]
        for k, off in product(probe.tolist(), [(-1, 0, 1), (2, -1, 0), (0, 0, 0)]):
            q = tuple(np.add(k, off).tolist())
            xn = ddst._walk(ddst.head, q[0])
            yn = ddst._walk(xn.child, q[1]) if xn is not None else None
            zn = ddst._walk(yn.child, q[2]) if yn is not None else None
            assert (zn is not None) == (idx.lookup(np.array([q]))[0] >= 0)
        # move a third of the cells: the DDST removes and re-inserts, the index re-files
        movers = rng.random(len(p)) < 0.33
        p = p.copy()
        p[movers] += rng.normal(size=(movers.sum(), 3)) * 3.0
        new_keys = [tuple(k) for k in box_keys(p, size).tolist()]
        for c in np.nonzero(movers)[0]:
            ddst.remove(int(c), keys[c])
            ddst.insert(int(c), new_keys[c])
        keys = new_keys
        idx = idx.moved(p)
    assert idx.n_boxes > 50
