// On the confirmation, choosing "I agree" after all makes the button a plain Continue.
for (const radio of document.querySelectorAll('input[name="decision"]')) {
  radio.addEventListener("change", () => {
    document.getElementById("consent-submit").textContent =
      radio.value === "decline" && radio.checked ? "Confirm" : "Continue";
  });
}
