# analysis.R: the report's tests again, in R, from the CSV files beside this script.
#
# Run it in the report's folder:   Rscript analysis.R
# It reads measures.csv (one value per participant or scenario, as hcss tested them),
# model_decisions.csv (every analysed decision of the human models) and the report's
# tables/*.csv (which rows hcss tested, with which options), runs each test with R's own
# functions, and writes r_pvalues.csv: one row per test, R's p beside hcss's.
#
#   Kruskal-Wallis        kruskal.test (tie-corrected chi-squared)
#   Tukey HSD             TukeyHSD(aov(value ~ group))
#   Friedman              friedman.test on participants with every model
#   paired Wilcoxon       wilcox.test(paired = TRUE, correct = TRUE), R's exact/normal choice
#   Mann-Whitney          wilcox.test(x, y, exact, correct) with the options hcss used
#   Spearman              cor.test(method = "spearman"), R's default p
#   GEE (success)         geepack::geeglm, binomial, exchangeable, robust SE
#   mixed model (time)    lme4::lmer, REML, Wald z p from the t value (as hcss)
#   logistic mixed model  lme4::glmer(binomial), Laplace: the subject-specific fit hcss does
#                         not compute (Python has only a variational Bayes approximation);
#                         printed, not compared
#
# Not here: Tukey-Kramer on Kruskal-Wallis mean ranks (MATLAB's multcompare; no R function)
# and Dunn-Holm (needs the dunn.test or FSA package).
#
# Paired differences are rounded to 12 significant digits before wilcox.test: hcss takes
# them on the exact values, and differences equal in exact arithmetic (130/600 - 119/600
# and 200/600 - 189/600) can differ in the last bit of a double.

suppressPackageStartupMessages({
  library(lme4)
  library(geepack)
})

measures <- read.csv("measures.csv", stringsAsFactors = FALSE)
measures$participant[is.na(measures$participant)] <- ""
read_table <- function(name) {
  path <- file.path("tables", paste0(name, ".csv"))
  if (file.exists(path)) read.csv(path, stringsAsFactors = FALSE) else data.frame()
}
results <- list()
add <- function(table, measure, split, key, p_hcss, p_r) {
  results[[length(results) + 1]] <<- data.frame(
    table = table, measure = measure, split = split, key = key,
    p_hcss = p_hcss, p_r = p_r, stringsAsFactors = FALSE
  )
}
chosen <- function(measure, split, groups) {
  measures[measures$measure == measure & measures$split == split &
             measures$group %in% groups & !is.na(measures$value), ]
}
human_blocks <- function(measure, split) {
  rows <- chosen(measure, split, c("M1", "M2", "M3"))
  rows <- rows[rows$participant != "", ]
  wide <- reshape(rows[, c("participant", "group", "value")], idvar = "participant",
                  timevar = "group", direction = "wide")
  names(wide) <- sub("^value\\.", "", names(wide))
  groups <- intersect(c("M1", "M2", "M3"), names(wide))
  wide[complete.cases(wide[, groups]), c("participant", groups), drop = FALSE]
}

# Kruskal-Wallis, and Tukey HSD on the same groups
for (row in seq_len(nrow(kw <- read_table("kruskal_wallis")))) {
  r <- kw[row, ]
  if (is.na(r$p)) next
  d <- chosen(r$measure, r$split, strsplit(r$groups, ",")[[1]])
  add("kruskal_wallis", r$measure, r$split, r$family, r$p,
      kruskal.test(value ~ factor(group), data = d)$p.value)
}
tukey <- read_table("tukey_hsd")
for (row in seq_len(nrow(tukey))) {
  r <- tukey[row, ]
  if (is.na(r$p)) next
  family <- kw[kw$measure == r$measure & kw$split == r$split & kw$family == r$family, ]
  d <- chosen(r$measure, r$split, strsplit(family$groups[1], ",")[[1]])
  fit <- TukeyHSD(aov(value ~ factor(group), data = d))[[1]]
  pair <- c(paste0(r$group_b, "-", r$group_a), paste0(r$group_a, "-", r$group_b))
  pair <- pair[pair %in% rownames(fit)][1]
  add("tukey_hsd", r$measure, r$split, paste(r$family, r$group_a, r$group_b),
      r$p, fit[pair, "p adj"])
}

# Friedman and paired Wilcoxon on participants with every model
friedman_rows <- read_table("friedman")
for (row in seq_len(nrow(friedman_rows))) {
  r <- friedman_rows[row, ]
  if (is.na(r$p)) next
  wide <- human_blocks(r$measure, r$split)
  add("friedman", r$measure, r$split, "", r$p,
      friedman.test(as.matrix(wide[, -1]))$p.value)
}
paired <- read_table("wilcoxon_paired")
for (row in seq_len(nrow(paired))) {
  r <- paired[row, ]
  if (is.na(r$p)) next
  wide <- human_blocks(r$measure, r$split)
  differences <- signif(wide[[r$group_a]] - wide[[r$group_b]], 12)
  p <- suppressWarnings(wilcox.test(differences, correct = TRUE)$p.value)
  add("wilcoxon_paired", r$measure, r$split, paste(r$group_a, r$group_b), r$p, p)
}

# Mann-Whitney of the simulation-only models, with the options hcss used
mw <- read_table("mann_whitney")
for (row in seq_len(nrow(mw))) {
  r <- mw[row, ]
  if (is.na(r$p)) next
  x <- chosen(r$measure, r$split, r$group_a)$value
  y <- chosen(r$measure, r$split, r$group_b)$value
  exact <- if (startsWith(r$method, "exact")) TRUE else if (grepl("ties", r$method)) NULL else FALSE
  correct <- !grepl("continuity=False", r$method)
  p <- suppressWarnings(wilcox.test(x, y, exact = exact, correct = correct)$p.value)
  add("mann_whitney", r$measure, r$split, paste(r$group_a, r$group_b), r$p, p)
}

# Spearman correlations with success rate: per model, and over participants' M1-M3 means
units <- measures[measures$split == "overall" & measures$group != "All", ]
mrt <- measures[measures$measure == "mrt.total" & measures$group == "All", ]
spearman <- read_table("spearman")
mrt_table <- read_table("spearman_mrt")
if (nrow(mrt_table)) spearman <- unique(rbind(spearman, mrt_table))
for (row in seq_len(nrow(spearman))) {
  r <- spearman[row, ]
  if (is.na(r$p)) next
  pooled <- grepl("participant means", r$group)
  groups <- if (pooled) c("M1", "M2", "M3") else r$group
  d <- units[units$group %in% groups, ]
  if (pooled) d$unit <- d$participant
  y <- tapply(d$value[d$measure == r$y], d$unit[d$measure == r$y], mean)
  if (r$x == "mrt.total") {
    people <- tapply(d$participant[d$measure == r$y], d$unit[d$measure == r$y], `[`, 1)
    x <- tapply(mrt$value, mrt$participant, mean)[people[names(y)]]
  } else {
    x <- tapply(d$value[d$measure == r$x], d$unit[d$measure == r$x], mean)[names(y)]
  }
  if (pooled) {  # means taken in a different order than hcss's: equal means must stay equal
    x <- signif(x, 12)
    y <- signif(y, 12)
  }
  p <- suppressWarnings(cor.test(as.numeric(x), as.numeric(y), method = "spearman")$p.value)
  add("spearman", paste(r$x, r$y), "overall", r$group, r$p, p)
}

# Decision-level models, with the order covariates hcss used (those that vary)
decisions_path <- "model_decisions.csv"
if (file.exists(decisions_path)) {
  d <- read.csv(decisions_path, stringsAsFactors = FALSE)
  d$model <- factor(d$model, levels = c("M1", "M2", "M3"))
  d$difficulty <- factor(d$difficulty, levels = c("easy", "difficult"))
  d <- d[order(d$participant), ]
  covariates <- character(0)
  if ("position" %in% names(d) && all(!is.na(d$position)) && length(unique(d$position)) > 1) {
    covariates <- c(covariates, "position")
  }
  if ("first_section" %in% names(d) && length(unique(d$first_section)) > 1) {
    d$first_section <- factor(d$first_section, levels = c("easy", "difficult"))
    covariates <- c(covariates, "first_section")
  }
  design <- paste(c("model * difficulty", covariates), collapse = " + ")
  label <- function(term) {
    term <- gsub("model|difficulty|first_section", "", term)
    term <- sub("^difficult$", "difficult", term)
    gsub(":", " × ", term)
  }
  compare <- function(table, fitted, p_column) {
    hcss <- read_table(table)
    if (!nrow(hcss)) return(invisible())
    for (term in rownames(fitted)[-1]) {
      name <- label(term)
      if (name == "difficult" && grepl("first_section", term)) name <- "difficult first"
      match <- hcss[hcss$term == name, ]
      if (nrow(match)) add(table, "", "", name, match$p[1], fitted[term, p_column])
    }
  }
  gee <- read_table("gee_success")
  if (nrow(gee)) {
    fit <- geeglm(as.formula(paste("as.numeric(correct) ~", design)),
                  id = factor(participant), data = d, family = binomial,
                  corstr = "exchangeable")
    compare("gee_success", summary(fit)$coefficients, "Pr(>|W|)")
    cat("\nLogistic mixed model (glmer, Laplace), subject-specific odds ratios:\n")
    glmm <- glmer(as.formula(paste("as.numeric(correct) ~", design, "+ (1 | participant)")),
                  data = d, family = binomial)
    print(summary(glmm)$coefficients)
  }
  if (nrow(read_table("mixedlm_time"))) {
    timed <- d[!is.na(d$decision_time_s) & d$decision_time_s > 0, ]
    fit <- lmer(as.formula(paste("log(decision_time_s) ~", design, "+ (1 | participant)")),
                data = timed, REML = TRUE)
    coefficients <- summary(fit)$coefficients
    coefficients <- cbind(coefficients, p = 2 * pnorm(-abs(coefficients[, "t value"])))
    compare("mixedlm_time", coefficients, "p")
    print(as.data.frame(VarCorr(fit)))
  }
}

table <- do.call(rbind, results)
if (is.null(table)) table <- data.frame(table = character(0), p_hcss = numeric(0), p_r = numeric(0))
write.csv(table, "r_pvalues.csv", row.names = FALSE)
if (nrow(table)) {
  # p below 1e-12 is compared absolutely: R's pchisq(lower.tail = FALSE) in geepack and
  # ptukey keep about 1e-14 absolute precision (geepack prints 0 for p = 4e-27)
  relative <- abs(table$p_r - table$p_hcss) / pmax(abs(table$p_hcss), 1e-12)
  cat(sprintf("\n%d p-values recomputed in R; largest relative difference %.2g (%s)\n",
              nrow(table), max(relative), table$table[which.max(relative)]))
} else {
  cat("\nNo tests in this report to recompute.\n")
}
