"""Task-oriented grasp synthesis: the NLP of Sections 5-6 (Pyomo), solved by IPOPT through CasADi or cyipopt."""
