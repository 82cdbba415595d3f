"""The skeleton SlowFast network (torch; imported only by training and export).

SlowFast (Feichtenhofer et al., 2019) adapted from video to skeleton sequences in
a joint-channel layout: the input is ``(B, 17 * 7, T)`` — every joint's normalised
position, velocity and known-flag is a channel — and all convolutions are
temporal (1D over time). Two pathways:

- *slow*: every ``alpha``-th frame (the last frame of the window included), many
  channels, temporal kernels only after the first layer (as in SlowFast, whose
  early slow layers are non-degenerate in space only);
- *fast*: every frame, ``beta`` times the channels, temporal kernels from the start;
- *lateral* connections fast -> slow after each stage: a time-strided convolution
  (kernel = stride = alpha) whose output is concatenated to the slow features.

Convolutions are causal (padded on the past side only) and the head sees both
the temporal mean and the last time step of each pathway, so the prediction is
about the newest frame of the window, which keeps streaming latency low.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn


@dataclass(frozen=True, slots=True)
class SlowFastConfig:
    in_channels: int = 119
    num_classes: int = 4
    window: int = 32
    alpha: int = 4
    slow_channels: int = 64
    beta: float = 1 / 8
    dropout: float = 0.2
    fast_pathway: bool = True  # False: the slow pathway alone (the ablation in MODEL_CARD.md)

    def __post_init__(self) -> None:
        if self.window % self.alpha:
            raise ValueError(f"window ({self.window}) must be a multiple of alpha ({self.alpha})")
        if self.fast_channels < 1:
            raise ValueError(f"beta x slow_channels must give at least one channel, got {self.beta}")

    @property
    def fast_channels(self) -> int:
        return round(self.slow_channels * self.beta)


class CausalConv(nn.Sequential):
    """Conv1d padded on the past side + BatchNorm + ReLU."""

    def __init__(self, cin: int, cout: int, kernel: int) -> None:
        super().__init__(
            nn.ConstantPad1d((kernel - 1, 0), 0.0),
            nn.Conv1d(cin, cout, kernel, bias=False),
            nn.BatchNorm1d(cout),
            nn.ReLU(inplace=True),
        )


class Lateral(nn.Sequential):
    """Fast -> slow: time-strided convolution to the slow frame rate, 2 x fast channels."""

    def __init__(self, cin: int, alpha: int) -> None:
        super().__init__(
            nn.Conv1d(cin, 2 * cin, kernel_size=alpha, stride=alpha, bias=False),
            nn.BatchNorm1d(2 * cin),
            nn.ReLU(inplace=True),
        )


class SkeletonSlowFast(nn.Module):
    """Input (B, C, T) features -> (B, num_classes) logits."""

    def __init__(self, cfg: SlowFastConfig) -> None:
        super().__init__()
        self.cfg = cfg
        cs, a = cfg.slow_channels, cfg.alpha
        cf = cfg.fast_channels if cfg.fast_pathway else 0
        if cfg.fast_pathway:
            self.fast1 = CausalConv(cfg.in_channels, cf, 5)
            self.fast2 = CausalConv(cf, cf, 3)
            self.fast3 = CausalConv(cf, cf, 3)
            self.lat1 = Lateral(cf, a)
            self.lat2 = Lateral(cf, a)
        self.slow1 = CausalConv(cfg.in_channels, cs, 1)
        self.slow2 = CausalConv(cs + 2 * cf, cs, 3)
        self.slow3 = CausalConv(cs + 2 * cf, cs, 3)
        self.drop = nn.Dropout(cfg.dropout)
        self.head = nn.Linear(2 * cs + 2 * cf, cfg.num_classes)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        a = self.cfg.alpha
        slow = self.slow1(x[:, :, a - 1 :: a])  # the last frame of the window is a slow frame
        if not self.cfg.fast_pathway:
            slow = self.slow3(self.slow2(slow))
            return self.head(self.drop(torch.cat([slow.mean(dim=2), slow[:, :, -1]], dim=1)))
        fast = self.fast1(x)
        slow = self.slow2(torch.cat([slow, self.lat1(fast)], dim=1))
        fast = self.fast2(fast)
        slow = self.slow3(torch.cat([slow, self.lat2(fast)], dim=1))
        fast = self.fast3(fast)
        pooled = torch.cat(
            [slow.mean(dim=2), slow[:, :, -1], fast.mean(dim=2), fast[:, :, -a:].mean(dim=2)], dim=1
        )
        return self.head(self.drop(pooled))


class SlowFastEnsemble(nn.Module):
    """Several skeleton SlowFast networks trained from different seeds (and data draws): the mean of
    their logits (the geometric mean of their probabilities once a softmax follows). One network's
    judgement varies with its seed more than the behaviour tests allow; the mean varies less."""

    def __init__(self, members: list[SkeletonSlowFast]) -> None:
        super().__init__()
        if not members:
            raise ValueError("an ensemble needs at least one member")
        self.members = nn.ModuleList(members)

    @property
    def cfg(self) -> SlowFastConfig:
        """The members' architecture (alike)."""
        first: SkeletonSlowFast = self.members[0]  # type: ignore[assignment]
        return first.cfg

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.stack([m(x) for m in self.members]).mean(dim=0)
