"""Independent moduli beside the tensile tests (``reference_moduli:``, the paper's Table 4): each as
an observation of the model's linear moduli at its time scale (terms.py), the linearized analysis
with those in the data (condition.py), and a reference against the model's prediction
(compare.py)."""
