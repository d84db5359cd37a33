"""What a request meets before a view acts on it: bounds on what a client may send
(`hardening`), which client it counts as (`clients`), and the limit on Starts through a
public study link (`ratelimit`)."""
