"""mavlink."""
