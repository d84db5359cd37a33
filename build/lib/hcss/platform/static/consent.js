// On the confirmation, choosing "I agree" after all makes the button a plain Continue.
document.querySelectorAll('input[name="decision"]').forEach((radio) => radio.addEventListener("change", () => {
  document.getElementById("consent-submit").textContent = radio.value === "decline" && radio.checked ? "Confirm" : "Continue";
}));
