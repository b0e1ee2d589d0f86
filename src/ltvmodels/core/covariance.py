"""Compact posterior covariances of the coefficients k_t, shared by rows where possible."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CovarianceBlocks"]


@dataclass
class CovarianceBlocks:
    """Compact posterior covariance of k_t (in units of σ², i.e. blocks of H⁻¹).

    Either ``rowwise`` — ``blocks`` is (G, N, p, p) and row i of Θ_t has
    covariance ``row_scale[i] * blocks[row_group[i]]`` (``row_scale`` None:
    1), rows independent — or ``full`` — ``blocks`` is (N, K, K).
    """

    blocks: np.ndarray
    row_group: np.ndarray | None
    row_scale: np.ndarray | None = None

    def scale_inplace(self, factor: float) -> CovarianceBlocks:
        self.blocks *= factor
        return self

    def scale_rows(self, factors: np.ndarray) -> CovarianceBlocks:
        """Covariance with output row i scaled by ``factors[i]`` (per-output noise variance).

        In rowwise form rows that shared a block but get different factors get
        blocks of their own; the full form needs equal factors.
        """
        factors = np.asarray(factors, dtype=float)
        if np.all(factors == factors[0]):
            return self.scale_inplace(float(factors[0]))
        if self.row_group is None:
            raise ValueError("per-output scaling of a covariance that couples the rows")
        # kept as factors, not applied: the blocks stay shared (no n-fold copy)
        self.row_scale = factors * (1.0 if self.row_scale is None else self.row_scale)
        return self

    def scales(self, n: int) -> np.ndarray:
        """The factor of each output row, shape (n,)."""
        return np.ones(n) if self.row_scale is None else self.row_scale

    @property
    def shared(self) -> bool:
        """Every row has the same (N, p, p) covariance."""
        return (
            self.row_group is not None
            and self.blocks.shape[0] == 1
            and (self.row_scale is None or bool(np.all(self.row_scale == self.row_scale[0])))
        )

    def rows(self, n: int) -> np.ndarray:
        """The (N, n, p, p) covariances of the rows of Θ_t (rowwise form only)."""
        if self.row_group is None:
            raise ValueError("row covariances of a full covariance, which couples the rows")
        scales = self.scales(n)
        return np.stack([scales[i] * self.blocks[g] for i, g in enumerate(self.row_group)], axis=1)

    def full(self, n: int, p: int) -> np.ndarray:
        """The (N, K, K) covariance, K = n·p (rows independent in rowwise form)."""
        if self.row_group is None:
            return self.blocks
        N = self.blocks.shape[1]
        full = np.zeros((N, n, p, n, p))
        scales = self.scales(n)
        for i in range(n):
            full[:, i, :, i, :] = scales[i] * self.blocks[self.row_group[i]]
        return full.reshape(N, n * p, n * p)
