"""The pressure relations (CFz, CFx, CFy, CMz, camber, sidewall) as fit problems, the form
each one takes in the .tir, and the plan of which relations a folder's fit runs."""
