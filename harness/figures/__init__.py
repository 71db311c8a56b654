"""The paper's figures: their registry (worlds, variants, claims), running one end to end or replaying
a log, and the fidelity study over them."""
