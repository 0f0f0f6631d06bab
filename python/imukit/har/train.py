"""Training and evaluation of one HAR model, as the paper: Adam (lr 1e-3), the learning rate times
0.9 every 10 epochs (StepLR), the checkpoint with the best validation macro F1 evaluated on the
test windows; online augmentation per mini-batch (`augmentation.py`); fixed seeds and an explicit
number of CPU threads. Nothing is written to disk: the best weights are kept in memory.
"""
import copy
import ctypes
import dataclasses
import time

import numpy as np
import torch
import torch.nn.functional as F

from .augmentation import GumbelPolicy
from .models import build_model, parameter_count


@dataclasses.dataclass
class TrainConfig:
    model: str = "deepconvlstm"
    tiny: bool = False            # 32 filters, 64 recurrent units (CI smoke test)
    epochs: int = 30
    patience: int = 0             # stop after this many epochs without a better validation F1 (0: never)
    batch_size: int = 64
    # Mini-batches per epoch; 0: one pass over the training windows. A fixed count gives every
    # training-set size the same updates, validations, learning-rate steps and patience (the
    # fewer-subjects curve: one subject's pass is a sixth of six subjects').
    steps_per_epoch: int = 0
    lr: float = 1e-3
    lr_step_epochs: int = 10
    lr_gamma: float = 0.9
    seed: int = 0
    threads: int = 1              # torch CPU threads (intra-op); inter-op is 1
    eval_batch: int = 512


def macro_f1(y_true, y_pred):
    """Mean F1 over the classes present in y_true or y_pred (scikit-learn's macro average)."""
    y_true = np.asarray(y_true)
    y_pred = np.asarray(y_pred)
    scores = []
    for c in np.union1d(y_true, y_pred):
        tp = np.sum((y_true == c) & (y_pred == c))
        wrong = np.sum((y_true == c) != (y_pred == c))  # false positives + false negatives
        scores.append(2.0 * tp / (2.0 * tp + wrong))
    return float(np.mean(scores)) if scores else 0.0


def blas_library():
    """The BLAS that torch's matrix products run in: Debian's torch calls the system libblas.so.3
    (OpenBLAS when libopenblas0 is installed, as scripts/setup.sh does: a DeepConvLSTM training
    step takes 162 ms with it and 283 ms with Debian's ATLAS: bench/har_step.py). The shared object's path, or ''."""
    with open("/proc/self/maps") as maps:
        for line in maps:
            path = line.split()[-1]
            if path.rsplit("/", 1)[-1].startswith("libblas.so"):
                return path
    return ""


def set_threads(threads):
    """torch's intra-op threads, and as many for OpenBLAS, which torch does not tell (by default
    it starts a thread per core in every worker process); inter-op work (none in this loop) gets
    one thread, set once per process: torch refuses (by aborting, in a forked worker) to set it
    again."""
    torch.set_num_threads(threads)
    path = blas_library()
    if path:
        openblas_set = getattr(ctypes.CDLL(path), "openblas_set_num_threads", None)
        if openblas_set is not None:
            openblas_set(threads)
    global _interop_set
    if not _interop_set and torch.get_num_interop_threads() != 1:
        torch.set_num_interop_threads(1)
    _interop_set = True


_interop_set = False


def predict(model, X, batch):
    model.eval()
    out = []
    with torch.no_grad():
        for a in range(0, len(X), batch):
            out.append(torch.argmax(model(torch.from_numpy(X[a:a + batch])), dim=1).numpy())
    return np.concatenate(out) if out else np.empty(0, np.int64)


def evaluate(model, X, y, batch=512):
    """(macro F1, accuracy) of model on standardised windows X with labels y."""
    p = predict(model, X, batch)
    return macro_f1(y, p), float(np.mean(p == y))


def policy_hypergradient(model, train_input, y, logits, grads, Xv, yv, xi):
    """d L_val(w - xi grad_w L_train(w, a)) / d a for the policy logits a, with the second-order
    term by central differences (Liu et al., DARTS, eqs. 7-8; the first-order term is zero: the
    validation loss does not depend on a directly):
    v = grad_w L_val(w'), w' = w - xi grads, w+- = w +- eps v, eps = 0.01 / |v|,
    result = -xi (grad_a L_train(w+) - grad_a L_train(w-)) / (2 eps).
    train_input() builds the gated training batch (a fresh graph to the logits per call); grads
    are grad_w L_train(w) of the model's parameters. The weights are restored afterwards and
    both passes see the same dropout masks."""
    params = [p for p in model.parameters()]
    saved = [p.detach().clone() for p in params]
    with torch.no_grad():
        for p, g in zip(params, grads):
            p.sub_(xi * g)
    v = torch.autograd.grad(F.cross_entropy(model(Xv), yv), params)
    eps = 0.01 / float(torch.sqrt(sum(torch.sum(g * g) for g in v)) + 1e-12)
    state = torch.get_rng_state()
    grad_a = []
    for sign in (1.0, -1.0):
        with torch.no_grad():
            for p, w, g in zip(params, saved, v):
                p.copy_(w + sign * eps * g)
        torch.set_rng_state(state)
        loss = F.cross_entropy(model(train_input()), y)
        grad_a.append(torch.autograd.grad(loss, logits)[0])
    with torch.no_grad():
        for p, w in zip(params, saved):
            p.copy_(w)
    return -xi * (grad_a[0] - grad_a[1]) / (2.0 * eps)


class Trainer:
    """One training run: train windows (raw), standardised validation and test windows, a
    BatchAugmenter and a sub-policy sampler (SubPolicySampler or GumbelPolicy)."""

    def __init__(self, config, classes, channels, augmenter, sampler):
        self.config = config
        self.classes = classes
        set_threads(config.threads)
        torch.manual_seed(config.seed)
        self.model = build_model(config.model, channels, classes, tiny=config.tiny)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=config.lr)
        self.scheduler = torch.optim.lr_scheduler.StepLR(self.optimizer, config.lr_step_epochs,
                                                         config.lr_gamma)
        self.augmenter = augmenter
        self.sampler = sampler

    def _policy_step(self, X, y, k, noise, grads, Xv, yv):
        policy = self.sampler
        xi = self.optimizer.param_groups[0]["lr"]
        policy.optimizer.zero_grad()
        policy.logits.grad = policy_hypergradient(
            self.model, lambda: X * policy.gate(k, noise), y, policy.logits, grads, Xv, yv, xi)
        policy.optimizer.step()

    def fit(self, train, val_X, val_y, test_X=None, test_y=None, log=None):
        """Trains on `train` (Windows, raw); returns a dict of results (scores, epochs, timing)."""
        c = self.config
        order_rng = np.random.default_rng([c.seed, 1])
        # The learned arms' validation batches come from a stream of their own, so every arm of a
        # seed trains on the same window order (found in review, 2026-11-27: drawn from
        # order_rng, they moved the learned arms' training batches off the other arms' from the
        # first policy step on; protocol 2, experiments.Settings.protocol).
        val_rng = np.random.default_rng([c.seed, 2])
        learn = isinstance(self.sampler, GumbelPolicy)
        best = (-1.0, -1, None)
        history = []
        step_seconds = 0.0
        steps = 0
        drawn = np.zeros(len(self.augmenter.policy), np.int64)
        t_start = time.perf_counter()
        stale = 0
        queue = np.zeros(0, np.int64)  # window order carried across epochs (steps_per_epoch)
        for epoch in range(c.epochs):
            self.model.train()
            if c.steps_per_epoch:
                # The epoch's batches continue the last epoch's pass; each pass is a new order.
                need = c.steps_per_epoch * c.batch_size
                passes, have = [queue], len(queue)
                while have < need:
                    passes.append(order_rng.permutation(len(train)))
                    have += len(train)
                queue = np.concatenate(passes)
                perm, queue = queue[:need], queue[need:]
            else:
                perm = order_rng.permutation(len(train))
            losses = []
            # Whole batches only (the last partial one is dropped; its windows come first in
            # another epoch's order), at least one.
            for b in range(0, max(len(perm) // c.batch_size, 1) * c.batch_size, c.batch_size):
                t0 = time.perf_counter()
                index = perm[b:b + c.batch_size]
                k, noise = self.sampler.draw()
                drawn[k] += 1
                seed = (c.seed * 1_000_003 + epoch) * 100_003 + b
                Xb, yb = self.augmenter.batch(k, index, seed)
                X = torch.from_numpy(Xb)
                y = torch.from_numpy(yb)
                if learn:
                    X_in = X * self.sampler.gate(k, noise)
                else:
                    X_in = X
                loss = F.cross_entropy(self.model(X_in), y)
                self.optimizer.zero_grad()
                params = [p for p in self.model.parameters()]
                grads = torch.autograd.grad(loss, params)
                for p, g in zip(params, grads):
                    p.grad = g
                if learn and steps % self.sampler.every == 0:
                    vi = val_rng.choice(len(val_y), size=min(c.batch_size, len(val_y)), replace=False)
                    self._policy_step(X, y, k, noise, grads, torch.from_numpy(val_X[vi]),
                                      torch.from_numpy(val_y[vi]))
                self.optimizer.step()
                losses.append(float(loss))
                step_seconds += time.perf_counter() - t0
                steps += 1
            self.scheduler.step()
            f1, acc = evaluate(self.model, val_X, val_y, c.eval_batch)
            history.append({"epoch": epoch, "loss": float(np.mean(losses)), "val_f1": f1, "val_acc": acc})
            if log:
                log(f"epoch {epoch:3d} loss {np.mean(losses):.4f} val F1 {f1:.4f} acc {acc:.4f}")
            if f1 > best[0]:
                best = (f1, epoch, copy.deepcopy(self.model.state_dict()))
                stale = 0
            else:
                stale += 1
                if c.patience and stale >= c.patience:
                    break
        self.model.load_state_dict(best[2])
        result = {
            "best_epoch": best[1], "epochs_run": len(history), "val_f1": best[0],
            "parameters": parameter_count(self.model), "steps": steps,
            "augmented_windows": self.augmenter.augmented_windows,
            "seconds": time.perf_counter() - t_start,
            "blas": blas_library(),
            "step_seconds_mean": step_seconds / max(steps, 1),
            "imukit_seconds": self.augmenter.imukit_seconds,
            "imukit_share": self.augmenter.imukit_seconds / step_seconds if step_seconds > 0 else 0.0,
            "history": history,
            "sub_policies_drawn": int(np.count_nonzero(drawn)),
        }
        if learn:
            p = self.sampler.probabilities
            top = np.argsort(p)[::-1][:10]
            result["learned_top"] = [{"index": int(i), "p": float(p[i]),
                                      "sub_policy": self.augmenter.policy.describe()[i]} for i in top]
            identity = [i for i, s in enumerate(self.augmenter.policy.sub_policies) if s.is_identity]
            result["learned_identity_p"] = float(sum(p[i] for i in identity))
        if test_X is not None:
            result["test_f1"], result["test_acc"] = evaluate(self.model, test_X, test_y, c.eval_batch)
        return result
