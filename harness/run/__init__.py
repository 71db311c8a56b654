"""Running a stream: the one stream loop and what every command shares to run it (run directories, worker
processes, the size budget, progress, configuration files, scales derived from a log)."""
