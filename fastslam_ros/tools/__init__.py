"""Command-line tools: simulator, bag replay and playback, evaluation, converters, benchmarks."""
