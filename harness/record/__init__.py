"""What a run records besides its metrics: the Rerun recording and its blueprint, screenshots of it,
and observation logs written to a file (a simulated world's, and the output check of every import)."""
