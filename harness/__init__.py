"""The harness around the SLAM packages: the paper's figures (``figures``), robustness sweeps
(``sweeps``) and navigation experiments (``navigation``), on the shared running of a stream
(``run``), the camera stream (``camera``), measuring and reporting (``report``) and recording
(``record``); the command line (``cli``) on top. Each sub-package imports only from those below
it (ARCHITECTURE.md)."""
