"""A small multi-task 1-D convolutional network for gear-pitting diagnosis.

Five strided convolution blocks (convolution, batch normalisation, ReLU) halve the
length at each block; global average, maximum and root-mean-square pooling make
the network accept any input length (the RMS pool lets it read energies such as
the energy ratio of the TSA difference signal directly); one shared hidden layer
feeds three heads:

- ``severity_class``: logits over the severity classes;
- ``severity``: the pitted fraction, a regression output (scaled by the training
  maximum, see :class:`models.io.ModelSpec`);
- ``teeth``: logits over the pitted-teeth classes (``0, 1, 2, 3+``).

Optional side inputs (``n_side``, e.g. the known speed and load, see
:mod:`models.operating`) are concatenated to the pooled features before the
shared layer.

With the default widths the network has about 1.2e5 parameters.

References
----------
.. [1] Zhang, W., Peng, G., Li, C., Chen, Y., Zhang, Z. (2017). A new deep
   learning model for fault diagnosis with good anti-noise and domain adaptation
   ability on raw vibration signals. Sensors 17(2), 425 (wide first kernel,
   small kernels after, batch normalisation).
.. [2] Caruana, R. (1997). Multitask learning. Machine Learning 28, 41-75.
"""
from __future__ import annotations

import torch
from torch import nn

from gearpit.errors import require

DEFAULT_WIDTHS: tuple[int, ...] = (16, 32, 48, 64, 96)


def _block(c_in: int, c_out: int, kernel: int, padding_mode: str) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv1d(c_in, c_out, kernel_size=kernel, stride=2, padding=kernel // 2, bias=False, padding_mode=padding_mode),
        nn.BatchNorm1d(c_out),
        nn.ReLU(),
        nn.Conv1d(c_out, c_out, kernel_size=3, padding=1, bias=False, padding_mode=padding_mode),
        nn.BatchNorm1d(c_out),
        nn.ReLU(),
    )


class GearCNN(nn.Module):
    """Multi-task 1-D CNN (see module docstring).

    Parameters
    ----------
    in_channels : int
        Channels of the input representation.
    n_severity_classes, n_teeth_classes : int
        Sizes of the two classification heads.
    widths : tuple of int
        Channels of the five convolution blocks.
    hidden : int
        Width of the shared hidden layer.
    dropout : float
        Dropout before the heads.
    circular : bool
        Circular padding, for inputs that are one period of the shaft angle (TSA).
    n_side : int
        Number of side inputs (scalars per record) joined to the pooled features.
    """

    def __init__(self, in_channels: int, n_severity_classes: int, n_teeth_classes: int, *,
                 widths: tuple[int, ...] = DEFAULT_WIDTHS, hidden: int = 64, dropout: float = 0.2,
                 circular: bool = False, n_side: int = 0):
        super().__init__()
        require(in_channels >= 1, "in_channels", in_channels, "an integer >= 1")
        require(n_severity_classes >= 2, "n_severity_classes", n_severity_classes, "an integer >= 2")
        require(n_teeth_classes >= 1, "n_teeth_classes", n_teeth_classes, "an integer >= 1")
        require(n_side >= 0, "n_side", n_side, "an integer >= 0")
        require(len(widths) >= 1 and all(w >= 1 for w in widths), "widths", widths, "positive integers")
        blocks, c = [], in_channels
        for i, w in enumerate(widths):
            blocks.append(_block(c, w, 9 if i == 0 else 5, "circular" if circular else "zeros"))
            c = w
        # batch-normalise each input channel: a channel of small values (the TSA difference signal) is scaled
        # up by the batch statistics while its level relative to other records is kept
        self.features = nn.Sequential(nn.BatchNorm1d(in_channels), *blocks)
        self.n_side = int(n_side)
        self.shared = nn.Sequential(nn.Linear(3 * c + self.n_side, hidden), nn.ReLU(), nn.Dropout(dropout))
        self.severity_class = nn.Linear(hidden, n_severity_classes)
        self.severity = nn.Linear(hidden, 1)
        self.teeth = nn.Linear(hidden, n_teeth_classes)

    def forward(self, x: torch.Tensor, side: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
        """``x``: (batch, channels, length), ``side``: (batch, n_side) or None -> dict of head outputs
        (logits, scaled severity)."""
        pooled = self.pooled(x)
        parts = [pooled]
        if self.n_side:
            require(side is not None and tuple(side.shape) == (x.shape[0], self.n_side), "side",
                    None if side is None else tuple(side.shape), f"a ({x.shape[0]}, {self.n_side}) tensor")
            parts.append(side)
        h = torch.cat(parts, dim=1)
        h = self.shared(h)
        return {"severity_class": self.severity_class(h), "severity": self.severity(h).squeeze(1),
                "teeth": self.teeth(h), "features": pooled}

    def pooled(self, x: torch.Tensor) -> torch.Tensor:
        """The convolution features pooled over the input's length (mean, max, RMS of each channel):
        ``(batch, 3 * widths[-1])``, what the heads read besides the side inputs (and what
        :mod:`models.novelty` measures the distance to the training records in)."""
        h = self.features(x)
        return torch.cat([h.mean(dim=2), h.amax(dim=2), torch.sqrt(h.square().mean(dim=2) + 1e-8)], dim=1)


def count_parameters(model: nn.Module) -> int:
    """Number of trainable parameters."""
    return int(sum(p.numel() for p in model.parameters() if p.requires_grad))
