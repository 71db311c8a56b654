"""What a run records besides its metrics: the Rerun recording and its blueprint, screenshots of it,
and a simulated world written as an observation log."""
