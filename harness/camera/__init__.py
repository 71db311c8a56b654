"""The simulated camera as a stream: rendered views matched into template numbers, and how well views
and images tell places apart."""
