"""Physics simulator of the Hydro Muscle test rigs (stand-in for lab data)."""
