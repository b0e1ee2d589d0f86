"""Compact posterior covariances of the coefficients k_t, shared by rows where possible."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class CovarianceBlocks:
    """Compact posterior covariance of k_t (in units of σ², i.e. blocks of H⁻¹).

    Either ``rowwise`` — ``blocks`` is (G, N, p, p) and row i of Θ_t has
    covariance ``blocks[row_group[i]]``, rows independent — or ``full`` —
    ``blocks`` is (N, K, K).
    """

    blocks: np.ndarray
    row_group: np.ndarray | None

    def scale_inplace(self, factor: float) -> CovarianceBlocks:
        self.blocks *= factor
        return self

    def full(self, n: int, p: int) -> np.ndarray:
        """The (N, K, K) covariance, K = n·p (rows independent in rowwise form)."""
        if self.row_group is None:
            return self.blocks
        N = self.blocks.shape[1]
        full = np.zeros((N, n, p, n, p))
        for i in range(n):
            full[:, i, :, i, :] = self.blocks[self.row_group[i]]
        return full.reshape(N, n * p, n * p)
