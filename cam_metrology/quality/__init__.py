"""Quality engineering on analysis results: SPC charts and capability (``spc``), gauge
repeatability and reproducibility by the ANOVA method (``gauge_rr``). Pure numerics."""
