# analysis.R: the report's tests again, in R, from the CSV files beside this script.
#
# Run it in the report's folder:   Rscript analysis.R
# It reads measures.csv (one value per participant or scenario, as hcss tested them),
# model_decisions.csv (every analysed decision of the human models) and the report's
# tables/*.csv (which rows hcss tested, with which options), runs each test with R's own
# functions, and writes r_pvalues.csv: one row per test, R's p, statistic and effect size
# beside hcss's. Before the tests it recomputes the measures it can from the tidy export
# (success rate and decision time from model_decisions.csv, the MRT total from the export's
# own MRT rows in mrt_scores.csv) and writes r_measures.csv, so a wrong measure shows too.
# It never stops: a table that is empty or not fitted is skipped with its reason, and a
# step that fails in R is a row of r_pvalues.csv with R's error in "note".
#
#   Kruskal-Wallis        kruskal.test (tie-corrected chi-squared)
#   Tukey HSD             TukeyHSD(aov(value ~ group))
#   Friedman              friedman.test on participants with every model
#   paired Wilcoxon       wilcox.test(paired = TRUE, correct = TRUE), R's exact/normal choice
#   Mann-Whitney          wilcox.test(x, y, exact, correct) with the options hcss used
#   Spearman              cor.test(method = "spearman"), R's default p
#   GEE (success)         geepack::geeglm, binomial, exchangeable, robust SE; below 40
#                         participants the jackknife from geepack's leave-one-out refits,
#                         (K - 1)/K, with t on K - p df (as hcss; its p_method says which)
#   mixed model (time)    lme4::lmer, REML, Wald z p from the t value; below 40 participants
#                         t on nlme::lme's between/within df (as hcss); and its CR2
#                         cluster-robust p on Satterthwaite df, clubSandwich::coef_test
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

read_csv_or_empty <- function(path) {
  # an empty file (no header) or a missing one is no rows, never a stop
  if (!file.exists(path) || file.info(path)$size == 0) return(data.frame())
  tryCatch(read.csv(path, stringsAsFactors = FALSE), error = function(e) data.frame())
}
measures <- read_csv_or_empty("measures.csv")
if (!nrow(measures)) {
  measures <- data.frame(measure = character(0), split = character(0), group = character(0),
                         unit = character(0), participant = character(0), value = numeric(0))
}
measures$participant[is.na(measures$participant)] <- ""
read_table <- function(name) {
  table <- read_csv_or_empty(file.path("tables", paste0(name, ".csv")))
  # a model that was not fitted is one row with its reason and no p: nothing to rerun
  if (nrow(table) && "p" %in% names(table) && all(is.na(table$p))) data.frame() else table
}
results <- list()
add <- function(table, measure, split, key, p_hcss, p_r, stat_hcss = NA, stat_r = NA,
                effect_hcss = NA, effect_r = NA, note = "") {
  results[[length(results) + 1]] <<- data.frame(
    table = table, measure = measure, split = split, key = key,
    p_hcss = p_hcss, p_r = p_r, stat_hcss = stat_hcss, stat_r = stat_r,
    effect_hcss = effect_hcss, effect_r = effect_r, note = note, stringsAsFactors = FALSE
  )
}
guard <- function(table, expr) {
  # a failure in R is recorded, not fatal: the rest of the script still runs
  tryCatch(expr, error = function(e) {
    add(table, "", "", "", NA, NA, note = paste("R error:", conditionMessage(e)))
  })
}
# matched-pairs rank-biserial r, as effectsize's rank_biserial(Pair(x, y) ~ 1) computes it
paired_rb <- function(d) {
  nz <- d[d != 0]
  r <- rank(abs(nz)) * sign(nz)
  n <- length(r)
  (sum(r[r > 0]) + sum(r[r < 0])) / (n * (n + 1) / 2)
}

# Measures recomputed from the tidy export, before any test uses them
measure_rows <- list()
add_measure <- function(measure, split, group, participant, hcss, r) {
  measure_rows[[length(measure_rows) + 1]] <<- data.frame(
    measure = measure, split = split, group = group, participant = participant,
    value_hcss = hcss, value_r = r, stringsAsFactors = FALSE
  )
}
hcss_value <- function(measure, split, group, participant) {
  row <- measures[measures$measure == measure & measures$split == split &
                    measures$group == group & measures$participant == participant, "value"]
  if (length(row)) row[1] else NA
}
guard("measures", {
  decisions <- read_csv_or_empty("model_decisions.csv")
  if (nrow(decisions)) {
    decisions$trial_id <- if ("trial_id" %in% names(decisions)) decisions$trial_id else ""
    for (split in c("overall", "easy", "difficult")) {
      chosen <- if (split == "overall") decisions else decisions[decisions$difficulty == split, ]
      keys <- unique(chosen[, c("participant", "model")])
      for (row in seq_len(nrow(keys))) {
        unit <- chosen[chosen$participant == keys$participant[row] &
                         chosen$model == keys$model[row], ]
        trials <- split(unit, unit$trial_id)
        success <- mean(sapply(trials, function(t) mean(t$correct == 1)))
        minutes <- sapply(trials, function(t) {
          s <- t$decision_time_s[!is.na(t$decision_time_s)]
          if (length(s)) sum(s) / (60 * length(s)) else NA
        })
        minutes <- if (all(is.na(minutes))) NA else mean(minutes, na.rm = TRUE)
        for (m in list(list("success_rate", success), list("decision_time_min", minutes))) {
          add_measure(m[[1]], split, keys$model[row], keys$participant[row],
                      hcss_value(m[[1]], split, keys$model[row], keys$participant[row]), m[[2]])
        }
      }
    }
  }
  mrt_rows <- read_csv_or_empty("mrt_scores.csv")
  for (person in unique(mrt_rows$participant)) {
    own <- mrt_rows[mrt_rows$participant == person, ]
    own <- own[!duplicated(own$scale, fromLast = TRUE), ]  # a corrected score is a later row
    # the total row, else both parts, else the participants table's stored total: one part
    # alone is half the test, not its score
    total <- if ("total" %in% own$scale) {
      own$score[own$scale == "total"]
    } else if (all(c("part_1", "part_2") %in% own$scale)) {
      sum(own$score[own$scale %in% c("part_1", "part_2")])
    } else if ("stored" %in% own$scale) {
      own$score[own$scale == "stored"]
    } else {
      NA
    }
    if (is.na(total)) next
    add_measure("mrt.total", "overall", "All", person,
                hcss_value("mrt.total", "overall", "All", person), total)
  }
})
measure_table <- do.call(rbind, measure_rows)
if (is.null(measure_table)) {
  measure_table <- data.frame(measure = character(0), value_hcss = numeric(0), value_r = numeric(0))
}
write.csv(measure_table, "r_measures.csv", row.names = FALSE)
if (nrow(measure_table)) {
  same <- (is.na(measure_table$value_hcss) & is.na(measure_table$value_r)) |
    (abs(measure_table$value_r - measure_table$value_hcss) <=
       1e-9 * pmax(abs(measure_table$value_hcss), 1e-12))
  same[is.na(same)] <- FALSE
  cat(sprintf("%d of %d measures recomputed in R from the export agree to 1e-9\n",
              sum(same), nrow(measure_table)))
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

# Kruskal-Wallis (H, epsilon^2 = H / (n - 1)), and Tukey HSD on the same groups
kw <- read_table("kruskal_wallis")
guard("kruskal_wallis", for (row in seq_len(nrow(kw))) {
  r <- kw[row, ]
  if (is.na(r$p)) next
  d <- chosen(r$measure, r$split, strsplit(r$groups, ",")[[1]])
  test <- kruskal.test(value ~ factor(group), data = d)
  add("kruskal_wallis", r$measure, r$split, r$family, r$p, test$p.value,
      r$H, unname(test$statistic), r$epsilon_squared, unname(test$statistic) / (nrow(d) - 1))
})
tukey <- read_table("tukey_hsd")
guard("tukey_hsd", for (row in seq_len(nrow(tukey))) {
  r <- tukey[row, ]
  if (is.na(r$p)) next
  family <- kw[kw$measure == r$measure & kw$split == r$split & kw$family == r$family, ]
  d <- chosen(r$measure, r$split, strsplit(family$groups[1], ",")[[1]])
  fit <- TukeyHSD(aov(value ~ factor(group), data = d))[[1]]
  pair <- c(paste0(r$group_b, "-", r$group_a), paste0(r$group_a, "-", r$group_b))
  pair <- pair[pair %in% rownames(fit)][1]
  add("tukey_hsd", r$measure, r$split, paste(r$family, r$group_a, r$group_b),
      r$p, fit[pair, "p adj"])
})

# Friedman (chi-squared, Kendall's W) and paired Wilcoxon (V, rank-biserial r)
friedman_rows <- read_table("friedman")
guard("friedman", for (row in seq_len(nrow(friedman_rows))) {
  r <- friedman_rows[row, ]
  if (is.na(r$p)) next
  wide <- human_blocks(r$measure, r$split)
  test <- friedman.test(as.matrix(wide[, -1]))
  add("friedman", r$measure, r$split, "", r$p, test$p.value, r$chi2, unname(test$statistic),
      r$kendall_w, unname(test$statistic) / (nrow(wide) * (ncol(wide) - 2)))
})
paired <- read_table("wilcoxon_paired")
guard("wilcoxon_paired", for (row in seq_len(nrow(paired))) {
  r <- paired[row, ]
  if (is.na(r$p)) next
  wide <- human_blocks(r$measure, r$split)
  differences <- signif(wide[[r$group_a]] - wide[[r$group_b]], 12)
  test <- suppressWarnings(wilcox.test(differences, correct = TRUE))
  add("wilcoxon_paired", r$measure, r$split, paste(r$group_a, r$group_b), r$p, test$p.value,
      r$V, unname(test$statistic), r$rank_biserial_r, paired_rb(differences))
})

# Mann-Whitney of the simulation-only models, with the options hcss used
mw <- read_table("mann_whitney")
guard("mann_whitney", for (row in seq_len(nrow(mw))) {
  r <- mw[row, ]
  if (is.na(r$p)) next
  x <- chosen(r$measure, r$split, r$group_a)$value
  y <- chosen(r$measure, r$split, r$group_b)$value
  exact <- if (startsWith(r$method, "exact")) TRUE else if (grepl("ties", r$method)) NULL else FALSE
  correct <- !grepl("continuity=False", r$method)
  test <- suppressWarnings(wilcox.test(x, y, exact = exact, correct = correct))
  w <- unname(test$statistic)
  add("mann_whitney", r$measure, r$split, paste(r$group_a, r$group_b), r$p, test$p.value,
      r$W, w, r$rank_biserial_r, 2 * w / (length(x) * length(y)) - 1)
})

# Spearman correlations with success rate: per model, and over participants' M1-M3 means
units <- measures[measures$split == "overall" & measures$group != "All", ]
mrt <- measures[measures$measure == "mrt.total" & measures$group == "All", ]
spearman <- read_table("spearman")
mrt_table <- read_table("spearman_mrt")
if (nrow(mrt_table)) spearman <- unique(rbind(spearman, mrt_table))
guard("spearman", for (row in seq_len(nrow(spearman))) {
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
  test <- suppressWarnings(cor.test(as.numeric(x), as.numeric(y), method = "spearman"))
  add("spearman", paste(r$x, r$y), "overall", r$group, r$p, test$p.value,
      r$rho, unname(test$estimate))
})

# Decision-level models, with the order covariates hcss used (those that vary)
d <- read_csv_or_empty("model_decisions.csv")
gee <- read_table("gee_success")
mixed <- read_table("mixedlm_time")
if (nrow(d) && (nrow(gee) || nrow(mixed))) {
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
    name <- gsub(":", " × ", gsub("model|difficulty|first_section", "", term))
    if (name == "difficult" && grepl("first_section", term)) name <- "difficult first"
    name
  }
  compare <- function(table, hcss, beta, se, p, ratio_column) {
    for (term in names(beta)[-1]) {
      match <- hcss[hcss$term == label(term), ]
      if (nrow(match)) {
        add(table, "", "", label(term), match$p[1], p[[term]],
            match[[ratio_column]][1], exp(beta[[term]]), note = "statistic: exp(beta)")
      }
    }
  }
  small_sample <- function(hcss) nrow(hcss) && startsWith(hcss$p_method[1], "t")
  if (nrow(gee)) guard("gee_success", {
    formula <- as.formula(paste("as.numeric(correct) ~", design))
    fit_gee <- function(data) geeglm(formula, id = factor(participant), data = data,
                                     family = binomial, corstr = "exchangeable")
    fit <- fit_gee(d)
    s <- summary(fit)$coefficients
    beta <- setNames(s[, 1], rownames(s))
    if (small_sample(gee)) {  # the jackknife from leave-one-out refits, t on K - p df
      people <- unique(d$participant)
      loo <- sapply(people, function(q) coef(fit_gee(d[d$participant != q, ])) - beta)
      k <- length(people)
      se <- sqrt((k - 1) / k * rowSums(loo^2))
      p <- 2 * pt(-abs(beta / se), k - length(beta))
    } else {
      p <- setNames(s[, "Pr(>|W|)"], rownames(s))
    }
    compare("gee_success", gee, beta, NULL, p, "odds_ratio")
    cat("\nLogistic mixed model (glmer, Laplace), subject-specific odds ratios:\n")
    glmm <- glmer(as.formula(paste("as.numeric(correct) ~", design, "+ (1 | participant)")),
                  data = d, family = binomial)
    print(summary(glmm)$coefficients)
  })
  if (nrow(mixed)) guard("mixedlm_time", {
    timed <- d[!is.na(d$decision_time_s) & d$decision_time_s > 0, ]
    fit <- lmer(as.formula(paste("log(decision_time_s) ~", design, "+ (1 | participant)")),
                data = timed, REML = TRUE)
    cf <- summary(fit)$coefficients
    beta <- setNames(cf[, "Estimate"], rownames(cf))
    if (small_sample(mixed)) {  # t on nlme's between/within df
      within <- sapply(rownames(cf)[-1], function(term) {
        column <- model.matrix(fit)[, term]
        any(tapply(column, timed$participant, function(v) length(unique(v)) > 1))
      })
      k <- length(unique(timed$participant))
      df <- c(nrow(timed) - k - sum(within),
              ifelse(within, nrow(timed) - k - sum(within), k - 1 - sum(!within)))
      p <- setNames(2 * pt(-abs(cf[, "t value"]), df), rownames(cf))
    } else {
      p <- setNames(2 * pnorm(-abs(cf[, "t value"])), rownames(cf))
    }
    compare("mixedlm_time", mixed, beta, NULL, p, "time_ratio")
    print(as.data.frame(VarCorr(fit)))
    # CR2 cluster-robust errors on Satterthwaite df (Bell-McCaffrey), as the report's CR2 columns
    if (!requireNamespace("clubSandwich", quietly = TRUE)) {
      add("mixedlm_time (CR2)", "", "", "", NA, NA, note = "clubSandwich is not installed")
    } else if ("robust_p" %in% names(mixed)) {
      robust <- clubSandwich::coef_test(fit, vcov = "CR2", test = "Satterthwaite",
                                        cluster = timed$participant)
      for (term in rownames(robust)[-1]) {
        match <- mixed[mixed$term == label(term), ]
        if (nrow(match)) {
          add("mixedlm_time (CR2)", "", "", label(term), match$robust_p[1],
              robust[term, "p_Satt"], match$robust_df[1], robust[term, "df_Satt"],
              note = "statistic: Satterthwaite df")
        }
      }
    }
  })
}

table <- do.call(rbind, results)
if (is.null(table)) {
  table <- data.frame(table = character(0), p_hcss = numeric(0), p_r = numeric(0),
                      note = character(0))
}
write.csv(table, "r_pvalues.csv", row.names = FALSE)
failed <- table[nzchar(table$note) & startsWith(table$note, "R error"), ]
for (row in seq_len(nrow(failed))) cat(sprintf("%s: %s\n", failed$table[row], failed$note[row]))
compared <- table[!is.na(table$p_hcss) & !is.na(table$p_r), ]
if (nrow(compared)) {
  # p below 1e-12 is compared absolutely: R's pchisq(lower.tail = FALSE) in geepack and
  # ptukey keep about 1e-14 absolute precision (geepack prints 0 for p = 4e-27)
  relative <- abs(compared$p_r - compared$p_hcss) / pmax(abs(compared$p_hcss), 1e-12)
  cat(sprintf("\n%d p-values recomputed in R; largest relative difference %.2g (%s)\n",
              nrow(compared), max(relative), compared$table[which.max(relative)]))
  stats <- compared[!is.na(compared$stat_hcss) & !is.na(compared$stat_r), ]
  if (nrow(stats)) {
    relative <- abs(stats$stat_r - stats$stat_hcss) / pmax(abs(stats$stat_hcss), 1e-12)
    cat(sprintf("%d statistics recomputed; largest relative difference %.2g (%s)\n",
                nrow(stats), max(relative), stats$table[which.max(relative)]))
  }
  effects <- compared[!is.na(compared$effect_hcss) & !is.na(compared$effect_r), ]
  if (nrow(effects)) {
    relative <- abs(effects$effect_r - effects$effect_hcss) / pmax(abs(effects$effect_hcss), 1e-12)
    cat(sprintf("%d effect sizes recomputed; largest relative difference %.2g (%s)\n",
                nrow(effects), max(relative), effects$table[which.max(relative)]))
  }
} else {
  cat("\nNo tests in this report to recompute.\n")
}
