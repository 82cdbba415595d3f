"""emitter stage."""
