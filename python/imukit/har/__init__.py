"""imukit.har: does augmentation make better activity recognisers? (docs/har.md)

- `recordings`: the labelled-recordings format (`imukit.recordings/1`) any dataset can be brought
  in; `utd_mhad`: UTD-MHAD into it.
- `windows`: sliding windows, majority labels, standardisation with training statistics.
- `models`: DeepConvLSTM and AttendAndDiscriminate (PyTorch).
- `augmentation`: online STDA / PPDA per mini-batch, fixed or learned sub-policy probabilities.
- `train`: the training loop (Adam, StepLR, best validation macro F1), `macro_f1`.
- `experiments`, `report`, `python3 -m imukit.har`: the experiments, their JSON, tables and plots;
  `arguments`: the command-line numbers, checked where they are parsed.

Needs PyTorch (Debian's python3-torch); SciPy for the paired tests, matplotlib for the plots.
"""
