"""Contact: obstacles, contact equilibria, self-contact, contact paths and contact-force design (issue 20)."""
