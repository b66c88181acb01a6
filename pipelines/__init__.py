"""Study definitions: each module wires hmid's stages for one kind of run (no algorithms here)."""
