"""Studies on measured data that go beyond the identification pipeline."""
