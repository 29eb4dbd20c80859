"""Assembly of shell and solid groups without label strings or COO triplets: the dofs of a group
are (node, direction) pairs, its element matrices are summed node block by node block into the
pattern of node pairs the elements couple, chunk by chunk, and the blocks are written once into
the CSR arrays of the model's dofs (supported dofs dropped).  The result equals the triplet route
of :func:`femupdate.structure.groups.triplets` (the same sums in another order, to rounding;
``tests/test_node_assembly.py``) at a fraction of its memory: no stack of every element's matrix,
no triplets, no duplicate entries to sort.

Dofs of integer nodes are coded as ``8 node + direction index`` (x, y, z, rx, ry, rz, s: 0 to 6),
which orders them as :func:`femupdate.dofs.sort_key` does."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from ..dofs import parse_dof, sort_key
from .groups import ElementGroup, NodeDofs

DIR_CODE = {"x": 0, "y": 1, "z": 2, "rx": 3, "ry": 4, "rz": 5, "s": 6}
_CODE_DIR = {v: k for k, v in DIR_CODE.items()}
#: elements whose matrices are computed at once (a hexahedron needs ~30 kB while its stack is made)
CHUNK = 2048


class DofTable:
    """The sorted dofs of a structure's groups: integer-node dofs as codes, named-node labels apart.

    ``codes`` (sorted int64) come first, then ``named`` (sorted by :func:`sort_key`).
    """

    def __init__(self, groups: list[ElementGroup], extra=()):
        code_parts, named = [], set()
        loose = set(extra)
        for g in groups:
            if isinstance(g.labels, NodeDofs):
                nodes = np.unique(g.labels.nodes)
                dirs = np.array([DIR_CODE[d] for d in g.labels.dirs])
                code_parts.append((nodes[:, None] * 8 + dirs[None]).ravel())
            else:
                loose.update(lab for row in g.labels for lab in row)
        for lab in loose:
            node, d = parse_dof(lab)
            if isinstance(node, int):
                code_parts.append(np.array([node * 8 + DIR_CODE[d]], np.int64))
            else:
                named.add(lab)
        self.codes = np.unique(np.concatenate(code_parts)) if code_parts else np.empty(0, np.int64)
        self.named = sorted(named, key=sort_key)
        self._named = set(named)

    def labels(self) -> list[str]:
        """Every label, in order."""
        return self.labels_of(self.codes) + self.named

    @staticmethod
    def labels_of(codes: np.ndarray) -> list[str]:
        """The labels of dof codes."""
        nodes, dirs = np.divmod(np.asarray(codes, np.int64), 8)
        names = [_CODE_DIR[d] for d in range(7)]
        return [f"{a}:{names[d]}" for a, d in zip(nodes.tolist(), dirs.tolist())]

    def contains(self, label: str) -> bool:
        """Whether ``label`` (canonical) is a dof of the table."""
        node, d = parse_dof(label)
        if not isinstance(node, int):
            return label in self._named
        c = node * 8 + DIR_CODE[d]
        i = int(np.searchsorted(self.codes, c))
        return i < len(self.codes) and int(self.codes[i]) == c

    def fixed(self, supports, support_nodes) -> tuple[np.ndarray, set[str]]:
        """Mask of the supported codes and the supported named labels."""
        int_nodes = [nd for nd in support_nodes if isinstance(nd, int)]
        mask = np.isin(self.codes // 8, np.array(int_nodes, np.int64)) if int_nodes else np.zeros(len(self.codes), bool)
        named_nodes = {nd for nd in support_nodes if not isinstance(nd, int)}
        fixed_named = {lab for lab in self.named if parse_dof(lab)[0] in named_nodes}
        sup_codes = []
        for lab in supports:
            node, d = parse_dof(lab)
            if isinstance(node, int):
                sup_codes.append(node * 8 + DIR_CODE[d])
            else:
                fixed_named.add(lab)
        if sup_codes:
            mask |= np.isin(self.codes, np.array(sup_codes, np.int64))
        return mask, fixed_named

    @staticmethod
    def index_rows(rows, codes: np.ndarray, named_index: dict) -> np.ndarray:
        """Model dof index of each label of ``rows`` (equal-length lists), -1 for a supported dof."""
        cache: dict[str, int] = {}
        out = np.empty((len(rows), len(rows[0]) if len(rows) else 0), np.int64)
        for e, row in enumerate(rows):
            for j, lab in enumerate(row):
                i = cache.get(lab)
                if i is None:
                    node, d = parse_dof(lab)
                    if isinstance(node, int):
                        c = node * 8 + DIR_CODE[d]
                        p = int(np.searchsorted(codes, c))
                        i = p if p < len(codes) and int(codes[p]) == c else -1
                    else:
                        i = named_index.get(lab, -1)
                    cache[lab] = i
                out[e, j] = i
        return out

    def nodes(self) -> set:
        """The nodes (int or name) with a dof."""
        return set(np.unique(self.codes // 8).tolist()) | {parse_dof(lab)[0] for lab in self.named}

    def __len__(self) -> int:
        return len(self.codes) + len(self.named)


def node_block_pattern(q: np.ndarray, n_nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node-pair pattern of elements with node positions ``q`` ``(n_el, nn)``: CSR ``indptr``
    ``(n_nodes + 1,)``, ``cols`` (sorted within rows) and, per element node pair ``(a, b)`` in
    C order, the block index ``inverse`` ``(n_el * nn * nn,)``."""
    n_el, nn = q.shape
    keys = (q[:, :, None].astype(np.int64) * n_nodes + q[:, None, :]).ravel()
    uniq, inverse = np.unique(keys, return_inverse=True)
    del keys
    rows, cols = np.divmod(uniq, n_nodes)
    indptr = np.zeros(n_nodes + 1, np.int64)
    np.cumsum(np.bincount(rows, minlength=n_nodes), out=indptr[1:])
    small = np.int32 if len(uniq) < 2**31 - 1 else np.int64
    return indptr, cols.astype(np.int32 if n_nodes < 2**31 - 1 else np.int64), inverse.astype(small).ravel()


def scatter(B: list, inverse: np.ndarray, unit: np.ndarray, coef: np.ndarray, k: int, n_blocks: int) -> None:
    """Add ``coef * unit`` (element stacks ``(c, nn k, nn k)``) into the node blocks ``B`` (one
    array ``(n_blocks,)`` or None per component ``k i + j`` of a block, made when first non-zero) at
    ``inverse`` (``c nn nn`` block indices, element node pairs in C order)."""
    c, ne, _ = unit.shape
    if c == 0:
        return
    nn = ne // k
    scaled = unit if np.all(coef == 1.0) else unit * coef[:, None, None]
    vals = scaled.reshape(c, nn, k, nn, k).transpose(2, 4, 0, 1, 3).reshape(k * k, -1)  # one row per component
    lo, hi = int(inverse.min()), int(inverse.max()) + 1
    loc = inverse - lo
    for j in range(k * k):
        col = vals[j]
        if np.any(col):
            if B[j] is None:
                B[j] = np.zeros(n_blocks)
            B[j][lo:hi] += np.bincount(loc, weights=col, minlength=hi - lo)


def _direction_entries(B: list, i: int, k: int, r_i: np.ndarray, c_ij: np.ndarray, with_values: bool):
    """Rows, columns (and values) of the kept entries of direction ``i``'s dof rows, in (block, j)
    order, for the blocks ``B`` (component arrays, already restricted to a range of blocks)."""
    comps = [j for j in range(k) if B[k * i + j] is not None]
    if not comps:
        return r_i[:0], r_i[:0], np.empty(0)
    V = np.column_stack([B[k * i + j] for j in comps])
    C = c_ij[:, comps]
    keep = (V != 0) & (r_i[:, None] >= 0) & (C >= 0)
    rows = np.broadcast_to(r_i[:, None], keep.shape)[keep]
    if not with_values:
        return rows, None, None
    return rows, C[keep], V[keep]


#: node blocks turned into CSR entries at once (bounds the transient memory of :func:`blocks_to_csr`)
BLOCK_CHUNK = 1 << 20


def _row_chunks(indptr: np.ndarray):
    """Ranges of node rows ``(u0, u1)`` holding about :data:`BLOCK_CHUNK` blocks each."""
    n_nodes = len(indptr) - 1
    u0 = 0
    while u0 < n_nodes:
        u1 = int(np.searchsorted(indptr, indptr[u0] + BLOCK_CHUNK, side="right")) - 1
        u1 = min(max(u1, u0 + 1), n_nodes)
        yield u0, u1
        u0 = u1


def blocks_to_csr(indptr: np.ndarray, cols: np.ndarray, B: list, D: np.ndarray, n: int) -> sp.csr_array:
    """The ``n x n`` CSR matrix of node blocks ``B`` (per block component, as :func:`scatter`;
    node-pair pattern ``indptr``, ``cols``), node ``u``'s direction ``i`` at model dof ``D[u, i]``
    (-1: dropped).  ``D`` must increase along its rows and then its columns where it is not -1 (dofs
    sorted by node, then direction), so that the entries come out sorted; exact zeros are left out.
    Node rows are taken a range at a time (each dof row lies in one range); ``B`` is consumed (its
    components set to None as they are written)."""
    k = D.shape[1]
    idx_t = np.int32 if n < 2**31 - 1 else np.int64
    D = D.astype(idx_t)

    def entries(u0, u1, i, with_values):
        b0, b1 = int(indptr[u0]), int(indptr[u1])
        row_node = np.repeat(np.arange(u0, u1), np.diff(indptr[u0:u1 + 1]))
        Bc = [None if x is None else x[b0:b1] for x in B]
        return _direction_entries(Bc, i, k, D[row_node, i], D[cols[b0:b1]], with_values)

    counts = np.zeros(n, np.int64)
    for u0, u1 in _row_chunks(indptr):  # first pass: the entries of each row
        for i in range(k):
            rows = entries(u0, u1, i, False)[0]
            if len(rows):
                counts[int(rows.min()):int(rows.max()) + 1] += np.bincount(rows - rows.min())
    out_ptr = np.zeros(n + 1, np.int64)
    np.cumsum(counts, out=out_ptr[1:])
    del counts
    nnz = int(out_ptr[-1])
    if nnz >= 2**31 - 1:
        idx_t = np.int64
    data = np.empty(nnz)
    indices = np.empty(nnz, idx_t)
    for i in range(k):  # each dof row comes from one direction i, its entries contiguous and in order
        for u0, u1 in _row_chunks(indptr):
            rows, cc, vv = entries(u0, u1, i, True)
            if not len(rows):
                continue
            start = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])  # rows are non-decreasing
            run = np.repeat(start, np.diff(np.r_[start, len(rows)]))
            pos = out_ptr[rows] + (np.arange(len(rows)) - run)
            data[pos] = vv
            indices[pos] = cc
            del pos, run, start, rows, cc, vv
        for j in range(k):  # direction i's components are written: free them
            B[k * i + j] = None
    A = sp.csr_array((data, indices, out_ptr.astype(idx_t)), shape=(n, n))
    A.has_sorted_indices = True
    A.has_canonical_format = True
    return A


def _chunk(g: ElementGroup, lo: int, hi: int) -> ElementGroup:
    sl = slice(lo, hi)
    assert isinstance(g.labels, NodeDofs) and g.nodes is not None
    return replace(g, labels=NodeDofs(g.labels.nodes[sl], g.labels.dirs), nodes=g.nodes[sl],
                   nu=None if g.nu is None else g.nu[sl], where=g.where[sl],
                   props={k: v[sl] for k, v in g.props.items()})


def assemble_node_group(g: ElementGroup, terms_of, owners_of, D_of, n: int, out: dict) -> None:
    """Assemble one shell or solid group into ``out[(target, owner)]`` (a list of CSR matrices).

    ``terms_of(group)`` gives the element terms of a group (of a chunk of it), ``owners_of(factors)``
    the per-element (coefficient, owner) of a term, ``D_of(node_ids, dirs)`` the model dof index of
    each (node, direction), -1 for a supported dof.
    """
    assert isinstance(g.labels, NodeDofs)
    nodes_el = g.labels.nodes
    k = len(g.labels.dirs)
    n_el = len(nodes_el)
    U, q = np.unique(nodes_el, return_inverse=True)
    q = q.reshape(nodes_el.shape)
    D = D_of(U, g.labels.dirs)
    probe = terms_of(_chunk(g, 0, 1))
    plans: list = []  # per target and term: (target, term index, coef, owner)
    subsets: dict = {}  # owner element subset -> (elements, pattern)
    blocks: dict = {}  # (target, owner) -> (subset key, B)
    for target, tl in (("K", probe.K), ("M", probe.M)):
        for ti, (factors, _) in enumerate(tl):
            coef, pid = owners_of(factors)
            plans.append((target, ti, coef, pid))
            for t in np.unique(pid).tolist():
                sel = np.flatnonzero(pid == t)
                key = sel.tobytes()
                if key not in subsets:
                    subsets[key] = (sel, node_block_pattern(q[sel], len(U)))
                if (target, t) not in blocks:
                    blocks[(target, t)] = (key, [None] * (k * k))
    nn2 = nodes_el.shape[1] ** 2
    for lo in range(0, n_el, CHUNK):
        hi = min(lo + CHUNK, n_el)
        terms = terms_of(_chunk(g, lo, hi))
        for target, ti, coef, pid in plans:
            unit = (terms.K if target == "K" else terms.M)[ti][1]
            for t in np.unique(pid[lo:hi]).tolist():
                key, B = blocks[(target, t)]
                sel, (_, _, inverse) = subsets[key]
                a, b = np.searchsorted(sel, [lo, hi])
                local = sel[a:b] - lo
                scatter(B, inverse[a * nn2:b * nn2], unit[local], coef[sel[a:b]], k, len(subsets[key][1][1]))
        del terms
    for (target, t), (key, B) in blocks.items():
        indptr, cols, _ = subsets[key][1]
        out.setdefault((target, t), []).append(blocks_to_csr(indptr, cols, B, D, n))
        blocks[(target, t)] = (key, None)


__all__ = ["DofTable", "DIR_CODE", "node_block_pattern", "scatter", "blocks_to_csr", "assemble_node_group"]
