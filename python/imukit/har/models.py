"""The two HAR models of the paper (Oishi et al., Table II), written from their publications.

Both take windows (batch, T, C) -- T samples of C channels -- and return class logits.

- DeepConvLSTM (Ordonez & Roggen, Sensors 2016): four convolutions along time only (kernel 5 x 1,
  64 filters, ReLU, no padding) applied to every channel alike, the 64 features of all C channels
  concatenated per time step, two LSTM layers of 128 units with dropout 0.5 on the input of
  each, and a linear classifier (after dropout 0.5) on the last time step.
- AttendAndDiscriminate (Abedin et al., IMWUT 2021): the same convolutions, then a self-attention
  across the sensor channels at every time step (query, key, value projections of the 64
  features, softmax over channels, a learned gate gamma starting at 0 so the block starts as
  the identity), dropout 0.5, two GRU layers of 128 units (dropout 0.25 between them), temporal
  attention (a linear score per time step, softmax over time, the weighted sum of the GRU
  outputs), dropout 0.5, and a linear classifier on that feature, as the authors' published code
  does ("attend-l2" is imukit's first version, with spectral normalisation and the classifier on
  the L2-normalised feature). The paper's center loss and mixup belong to its training recipe, not to the
  model; the evaluation trains both models with the same cross-entropy recipe, as Oishi et al.
  describe.

With the paper's REALDISP configuration (12 channels, 34 classes) the two have 658,274 and
522,916 parameters, with REALWORLD's (42, 8) 1,637,960 and 1,256,842: the counts of Oishi et
al.'s Table II (tests/python/har_test.py checks them).
"""
import functools

import torch
from torch import nn
import torch.nn.functional as F


class _TimeConvs(nn.Module):
    """Four (kernel x 1) convolutions along time, shared by every channel: (B, T, C) -> (B, F, T', C)."""

    def __init__(self, filters, kernel, layers=4):
        super().__init__()
        self.convs = nn.ModuleList(
            nn.Conv2d(1 if i == 0 else filters, filters, (kernel, 1)) for i in range(layers))

    def forward(self, x):
        x = x.unsqueeze(1)
        for conv in self.convs:
            x = F.relu(conv(x))
        return x

    def out_steps(self, T):
        return T - len(self.convs) * (self.convs[0].kernel_size[0] - 1)


class DeepConvLSTM(nn.Module):
    def __init__(self, channels, classes, filters=64, kernel=5, lstm_units=128, lstm_layers=2,
                 dropout=0.5):
        super().__init__()
        self.convs = _TimeConvs(filters, kernel)
        self.dropout = nn.Dropout(dropout)
        self.lstm = nn.LSTM(filters * channels, lstm_units, lstm_layers, batch_first=True,
                            dropout=dropout if lstm_layers > 1 else 0.0)
        self.classifier = nn.Linear(lstm_units, classes)

    def forward(self, x):
        B = x.shape[0]
        h = self.convs(x)                                          # (B, F, T', C)
        h = h.permute(0, 2, 1, 3).reshape(B, h.shape[2], -1)       # (B, T', F x C)
        h, _ = self.lstm(self.dropout(h))
        return self.classifier(self.dropout(h[:, -1]))


class _ChannelSelfAttention(nn.Module):
    """Self-attention over the C sensor channels of one time step's (F, C) features
    (SAGAN-style: o = gamma * V softmax(Q^T K) + x)."""

    def __init__(self, features, reduction=1, spectral_norm=False):
        super().__init__()
        sn = torch.nn.utils.parametrizations.spectral_norm

        def proj(out):
            conv = nn.Conv1d(features, out, 1)
            nn.init.kaiming_normal_(conv.weight)
            nn.init.zeros_(conv.bias)
            return sn(conv) if spectral_norm else conv

        self.query = proj(features // reduction)
        self.key = proj(features // reduction)
        self.value = proj(features)
        self.gamma = nn.Parameter(torch.zeros(1))

    def forward(self, x):                                          # (N, F, C)
        q, k, v = self.query(x), self.key(x), self.value(x)
        beta = torch.softmax(torch.bmm(q.transpose(1, 2), k), dim=1)  # (N, C, C)
        return self.gamma * torch.bmm(v, beta) + x


class AttendAndDiscriminate(nn.Module):
    """Abedin et al. 2021 as their published code builds it: the classifier reads the temporal
    attention's feature through dropout; the L2-normalised feature is only for their center
    loss, which is not used here. normalised_head=True is imukit's first version ("attend-l2",
    until 2026-11-27), kept so its committed results can be made again: spectrally normalised
    attention projections and the classifier on the L2-normalised feature, whose bounded logits
    learn more slowly under a fixed step budget."""

    def __init__(self, channels, classes, filters=64, kernel=5, gru_units=128, gru_layers=2,
                 dropout=0.5, dropout_rnn=0.25, dropout_classifier=0.5, normalised_head=False):
        super().__init__()
        self.normalised_head = normalised_head
        self.convs = _TimeConvs(filters, kernel)
        self.attention = _ChannelSelfAttention(filters, spectral_norm=normalised_head)
        self.dropout = nn.Dropout(dropout)
        self.gru = nn.GRU(filters * channels, gru_units, gru_layers, batch_first=True,
                          dropout=dropout_rnn if gru_layers > 1 else 0.0)
        self.temporal_score = nn.Linear(gru_units, 1)
        self.dropout_classifier = nn.Dropout(dropout_classifier)
        self.classifier = nn.Linear(gru_units, classes)

    def forward(self, x):
        B = x.shape[0]
        h = self.convs(x)                                          # (B, F, T', C)
        Fn, T, C = h.shape[1], h.shape[2], h.shape[3]
        # Every time step of every window attends over its channels in one batched call.
        steps = h.permute(0, 2, 1, 3).reshape(B * T, Fn, C)
        h = self.attention(steps).reshape(B, T, Fn * C)
        h, _ = self.gru(self.dropout(h))                           # (B, T, U)
        weights = torch.softmax(self.temporal_score(h).squeeze(-1), dim=1)
        z = torch.sum(weights.unsqueeze(-1) * h, dim=1)
        if self.normalised_head:
            z = F.normalize(z, p=2, dim=1)
        return self.classifier(self.dropout_classifier(z))


MODELS = {
    "deepconvlstm": DeepConvLSTM,
    "attend": AttendAndDiscriminate,
    "attend-l2": functools.partial(AttendAndDiscriminate, normalised_head=True),
}


def build_model(name, channels, classes, tiny=False):
    """A model by name (one of MODELS); tiny=True: half the filters and recurrent units (32, 64;
    a quarter of the parameters) for the CI smoke test, same structure."""
    if name not in MODELS:
        raise ValueError(f"unknown model '{name}' ({', '.join(MODELS)})")
    if tiny:
        units = {"lstm_units": 64} if name == "deepconvlstm" else {"gru_units": 64}
        return MODELS[name](channels, classes, filters=32, **units)
    return MODELS[name](channels, classes)


def parameter_count(model):
    return sum(p.numel() for p in model.parameters() if p.requires_grad)
