"""The camera as a stream: the simulated camera's views or a camera log's images matched into template
numbers and rotations, and how well views and images tell places apart."""
